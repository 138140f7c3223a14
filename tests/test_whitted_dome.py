"""Whitted's dome term under a textured dome: a sky of two colours split at the horizon must light an open floor
with the sky's colour (the ground below the horizon cannot reach a floor facing up), and a glossy wall must reflect
what its lobe sees, as the path tracer and the closed forms say. Oracles: float64 quadrature of the bilinearly
filtered texture (``shading_helpers.dome_integral``) and of a white GGX lobe with Kulla and Conty's multiple
scattering written from the microfacet model (``ggx_albedo_oracle``)."""

import numpy as np
import pytest
from ggx_albedo_oracle import ggx_albedo, smith_lambda
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


def floor_pixels(material, integrator, spp, to_world=None, facing_y=True, size=4):
    """``(size * size, 3)`` float64 pixels of an open floor through the origin whose front faces +Y (or +Z), lit only
    by the two-colour dome, seen head-on by an orthographic camera."""
    if facing_y:
        plane = quad((0, 0, 0), (40, 0, 0), (0, 0, -40), material=0)  # front +Y
        cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    else:
        plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), material=0)  # front +Z
        cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    dome = DomeLight(color=np.ones(3, np.float32), texture=two_colour_dome(),
                     to_world=np.eye(4) if to_world is None else to_world)
    scene = wrt.Scene(meshes=[plane], materials=[material], lights=[dome])
    img = wrt.render(scene, camera=cam, width=size, height=size, spp=spp, device="cpu", integrator=integrator,
                     max_depth=1, seed=7)
    return img.rgb.reshape(-1, 3).astype(np.float64)


def floor_radiance(material, integrator, spp, to_world=None, facing_y=True):
    """The mean of :func:`floor_pixels`."""
    return floor_pixels(material, integrator, spp, to_world, facing_y).mean(axis=0)


def assert_converges_to(pixels, expected, floor=2e-3):
    """The mean of ``pixels`` (independent estimates, one per row) lies within 4 standard errors of ``expected``
    (plus ``floor``: the quadrature's and the filtered horizon's share), and those errors are small."""
    error = pixels.std(axis=0) / np.sqrt(len(pixels))
    assert (error < 0.01).all(), error
    np.testing.assert_array_less(np.abs(pixels.mean(axis=0) - expected), 4 * error + floor)


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
    assert_converges_to(floor_pixels(metal, "whitted", spp=64, size=8), expected)
    assert_converges_to(floor_pixels(metal, "path", spp=64, size=8), expected)


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


def white_metal_reflection(wo, alpha, radiance, n=300):
    """``(3,)`` float64 integral over the hemisphere about +Z of ``f(wo, wi) radiance(wi) cos`` for a white metal
    (F = 1): the GGX lobe ``D G2 / (4 cos_o cos_i)`` (height-correlated Smith) plus Kulla and Conty's lobe
    ``(1 - E(cos_o)) (1 - E(cos_i)) / (pi (1 - E_avg))``; midpoint rule on an ``n x 2n`` grid."""
    theta = (np.arange(n) + 0.5) / n * (np.pi / 2)
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * (2 * np.pi)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    wi = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    d_omega = np.sin(t) * (np.pi / 2 / n) * (np.pi / n)
    mus = (np.arange(64) + 0.5) / 64
    albedos = np.array([ggx_albedo(alpha, m, nodes=64)[0] for m in mus])
    average = 2.0 * (albedos * mus).mean()
    cos_o, cos_i = wo[2], wi[..., 2]
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    a2 = alpha * alpha
    d = a2 / (np.pi * (h[..., 2] ** 2 * (a2 - 1) + 1) ** 2)
    single = d / (1 + smith_lambda(cos_o, alpha) + smith_lambda(cos_i, alpha)) / (4 * cos_o * cos_i)
    loss = (1 - np.interp(cos_o, mus, albedos)) * (1 - np.interp(cos_i, mus, albedos)) / (np.pi * (1 - average))
    return np.einsum("tp,tpc->c", (single + loss) * cos_i * d_omega, radiance(wi))


def two_colour_radiance(directions):
    """The filtered :func:`two_colour_dome` seen along world ``directions`` ``(..., 3)`` (+Y its pole; the texture
    is constant along rows, so only the polar angle matters)."""
    texture = two_colour_dome()[:, 0, :3].astype(np.float64)
    theta = np.arccos(np.clip(directions[..., 1], -1, 1)).reshape(-1)
    rows = linear_weights(theta / np.pi * len(texture), len(texture))
    return (rows @ texture).reshape(directions.shape)


def test_whitted_reflects_a_textured_dome_in_a_glossy_wall_as_its_lobe_sees_it():
    """A white metal wall (roughness 0.4) facing +Z, seen from 30 degrees below its normal: its mirror direction
    looks 30 degrees up into the sky and its lobe's tail reaches the ground. Whitted converges to the float64
    quadrature of the lobe times the dome (0.265, 0.441, 0.912) within 4 standard errors of its pixels; it
    reflected the dome's irradiance about the mirror direction, as blurred as a diffuse surface sees it (0.375,
    0.425, 0.763), and before that the dome's mean (0.55, 0.40, 0.525)."""
    up = np.radians(30.0)
    view = np.array([0.0, np.sin(up), -np.cos(up)])  # the camera looks up at the wall
    wall = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), material=0)  # front +Z
    cam = wrt.Camera.orthographic(eye=-3.0 * view, target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    dome = DomeLight(color=np.ones(3, np.float32), texture=two_colour_dome())
    metal = Material(diffuse_color=1.0, metallic=1.0, roughness=0.4)
    scene = wrt.Scene(meshes=[wall], materials=[metal], lights=[dome])
    img = wrt.render(scene, camera=cam, width=8, height=8, spp=64, device="cpu", integrator="whitted", seed=5)
    assert_converges_to(img.rgb.reshape(-1, 3).astype(np.float64), white_metal_reflection(-view, 0.4**2,
                                                                                          two_colour_radiance))


@pytest.mark.parametrize("textured", [False, True])
def test_whitted_lights_a_floor_under_a_dome_near_float32s_largest(textured):
    """A dome of radiance 1e38 (float32 holds it) lights an open white Lambertian floor with 1e38: the irradiance over
    pi of a constant dome is its radiance. The stored band-0 coefficient, about 3.5 times the radiance, overflowed
    float32 to inf, and Whitted's pixels were inf (and dropped) where the path tracer's are finite."""
    plane = quad((0, 0, 0), (40, 0, 0), (0, 0, -40), material=0)  # front +Y
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    texture = np.ones((8, 16, 4), np.float32) if textured else None
    dome = DomeLight(color=np.full(3, 1e38, np.float32), texture=texture)
    scene = wrt.Scene(meshes=[plane], materials=[LAMBERT], lights=[dome])
    img = wrt.render(scene, camera=cam, width=2, height=2, spp=1, device="cpu", integrator="whitted", max_depth=1)
    np.testing.assert_allclose(img.rgb.reshape(-1, 3).astype(np.float64), np.float64(np.float32(1e38)), rtol=1e-3)


def test_whitted_warns_of_a_dome_too_bright_for_float32_naming_it():
    """A dome of colour 1e38 over texels of 10 has radiance 1e39, past float32: no image can hold what sees it, and the
    warning names the dome where its pixels were inf and dropped without a word of it (its harmonics, held scaled by
    a power of two, wrt.radiance_scale, now fit)."""
    plane = quad((0, 0, 0), (40, 0, 0), (0, 0, -40), material=0)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    dome = DomeLight(color=np.full(3, 1e38, np.float32), texture=np.full((8, 16, 4), 10.0, np.float32), path="/Sky")
    scene = wrt.Scene(meshes=[plane], materials=[LAMBERT], lights=[dome])
    with pytest.warns(UserWarning, match=r"DomeLight /Sky: its radiance \(1e\+38: .* texels \(up to 10\) "
                                         r"reaches 1e\+39, past float32's range"):
        wrt.render(scene, camera=cam, width=2, height=2, spp=1, device="cpu", integrator="whitted", max_depth=1)
