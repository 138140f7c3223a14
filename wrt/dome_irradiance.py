"""The dome light's irradiance as nine spherical-harmonic coefficients (bands 0 to 2), for Whitted's dome term.

Ramamoorthi and Hanrahan 2001, "An Efficient Representation for Irradiance Environment Maps": the irradiance
``E(n)`` of an environment is its radiance convolved with the clamped cosine, which keeps bands 0, 1 and 2 scaled
by ``pi``, ``2 pi / 3`` and ``pi / 4`` and leaves the higher bands under 1% of it. The coefficients here are those of
``E(n) / pi``: a white Lambertian surface facing ``n`` under the unoccluded dome shows ``sum_k c_k Y_k(n)``. They are
exact for a constant dome (``c_0 Y_0`` is its radiance) and for one of two colours split by a plane through the centre
(a sky over a ground: a constant plus an odd function, whose band 2 is 0), and within a few percent otherwise.

The coefficients are projected at load in float64 from the bilinearly filtered lat-long image that
:func:`wrt.light_sampling.dome_radiance` looks up (longitude wrapping, latitude clamped at the poles), in the dome's
frame (+Y the pole, longitude 0 along +Z: ``wrt.light_sampling.dome_direction_uv``); the device turns world
directions into it with ``DeviceLights.dome_to_local``.
"""

import numpy as np
import warp as wp

from .floats import FLOAT32_MAX

wp.set_module_options({"fuse_fp": False, "enable_backward": False})  # device-independent rounding: see wrt/shade.py

# Real spherical harmonics of bands 0-2 at unit (x, y, z): Y_k = NORMS[k] * monomial k (see _basis).
NORMS = (0.28209479177387814, 0.4886025119029199, 0.4886025119029199, 0.4886025119029199, 1.0925484305920792,
         1.0925484305920792, 1.0925484305920792, 0.31539156525252005, 0.5462742152960396)
BAND_OF = (0, 1, 1, 1, 2, 2, 2, 2, 2)
COSINE_BANDS = (1.0, 2.0 / 3.0, 0.25)  # the clamped cosine's factor on each band, over pi
GAUSS_POINTS = 8  # Gauss-Legendre points per latitude interval between texel centres
ROWS_PER_CHUNK = 256  # texel rows converted to float64 at a time


@wp.func
def sh_irradiance(coeffs: wp.array[wp.vec3], d: wp.vec3):
    """``E(d) / pi`` of the nine coefficients ``coeffs`` (:func:`device_coefficients`: each times its harmonic's
    norm) at unit direction ``d`` of their frame, clamped at 0 (a bright sun's truncated series dips below 0
    opposite it)."""
    x = d[0]
    y = d[1]
    z = d[2]
    e = coeffs[0] + coeffs[1] * x + coeffs[2] * y + coeffs[3] * z
    e += coeffs[4] * (x * y) + coeffs[5] * (y * z) + coeffs[6] * (x * z)
    e += coeffs[7] * (3.0 * y * y - 1.0) + coeffs[8] * (z * z - x * x)
    return wp.max(e, wp.vec3(0.0))


def device_coefficients(coeffs: np.ndarray) -> tuple[np.ndarray, bool]:
    """``(9, 3)`` float32 ``coeffs`` (:func:`irradiance_coefficients`) each times its harmonic's norm, as
    :func:`sh_irradiance` reads them, and whether one was past float32's range (clamped to its largest).

    Scaled so, a constant dome's band 0 is its radiance, which float32 holds whenever the dome's colour does: the
    bare coefficient, about 3.5 times the radiance, overflowed to inf for a dome of 1e38, and Whitted's pixels
    with it. A textured dome's others stay below about twice its mean radiance."""
    scaled = np.asarray(coeffs, np.float64) * np.array(NORMS)[:, None]
    past = not bool(np.all(np.abs(scaled) <= FLOAT32_MAX))
    return np.clip(np.nan_to_num(scaled), -FLOAT32_MAX, FLOAT32_MAX).astype(np.float32), past


def _basis(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``(9, ...)`` the real spherical harmonics at polar angle ``theta`` from +Y and longitude ``phi`` from +Z
    towards +X (direction ``(sin theta sin phi, cos theta, sin theta cos phi)``)."""
    x = np.sin(theta) * np.sin(phi)
    y = np.cos(theta) + 0.0 * phi
    z = np.sin(theta) * np.cos(phi)
    monomials = [np.ones_like(x), x, y, z, x * y, y * z, x * z, 3 * y * y - 1, z * z - x * x]
    return np.stack([norm * m for norm, m in zip(NORMS, monomials)])


def irradiance_coefficients(color, texels: np.ndarray | None = None) -> np.ndarray:
    """``(9, 3)`` float64 coefficients of ``E(n) / pi`` for a dome of radiance ``color`` ``(3,)`` times ``texels``
    ``(H, W, 3)`` (a lat-long image, top row at +Y; None: a constant dome), in the dome's frame.

    The filtered image is piecewise linear between texel centres: along a row its Fourier modes ``m <= 2`` are the
    texels' discrete ones times the hat filter's ``sinc^2(m dphi / 2)``; across rows it is integrated against each
    basis function's latitude part by Gauss-Legendre quadrature (:data:`GAUSS_POINTS`) between the row centres (the
    filtered image's kinks), exact to rounding for these smooth integrands.
    """
    color = np.asarray(color, np.float64).reshape(3)
    radiance = np.zeros((9, 3))
    if texels is None:
        radiance[0] = color / NORMS[0]  # the integral of L Y_0 over the sphere: 4 pi Y_0 L
    else:
        radiance = _project(texels) * color
    return radiance * np.array([COSINE_BANDS[b] for b in BAND_OF])[:, None]


def _project(texels: np.ndarray) -> np.ndarray:
    """``(9, 3)`` integrals over the sphere of the bilinearly filtered lat-long ``texels`` times each harmonic."""
    hgt, wid = texels.shape[:2]
    # Fourier sums of each row over longitude, phi at the column centres (u = (x + 1/2) / W, phi = pi (1 - 2u)),
    # with the hat filter's factor: modes 1, sin, cos, sin 2, cos 2.
    phi = np.pi * (1.0 - 2.0 * (np.arange(wid) + 0.5) / wid)
    dphi = 2.0 * np.pi / wid
    modes = np.stack([np.ones(wid), np.sin(phi), np.cos(phi), np.sin(2 * phi), np.cos(2 * phi)], -1)
    hat = np.sinc(np.array([0.0, 1.0, 1.0, 2.0, 2.0]) * dphi / (2.0 * np.pi)) ** 2  # np.sinc(x) = sin(pi x) / (pi x)
    rows = np.empty((hgt, 3, 5))
    for start in range(0, hgt, ROWS_PER_CHUNK):  # float64 a few rows at a time: an 8k dome's channel alone is 256 MB
        chunk = texels[start:start + ROWS_PER_CHUNK]
        for c in range(3):
            rows[start:start + ROWS_PER_CHUNK, c] = chunk[..., c].astype(np.float64) @ modes
    rows *= hat * dphi
    # Latitude: quadrature points between the row centres (and the poles) and the two rows each blends (clamped beyond
    # the first and last centres).
    edges = np.concatenate([[0.0], (np.arange(hgt) + 0.5) / hgt * np.pi, [np.pi]])
    nodes, node_weights = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    half = 0.5 * np.diff(edges)[:, None]
    theta = ((edges[:-1, None] + edges[1:, None]) * 0.5 + half * nodes).reshape(-1)
    n = len(theta)
    s = np.clip(theta / np.pi * hgt - 0.5, 0.0, hgt - 1.0)
    r0 = np.minimum(np.floor(s).astype(np.int64), hgt - 1)
    r1 = np.minimum(r0 + 1, hgt - 1)
    t = s - r0
    filtered = rows[r0] * (1.0 - t)[:, None, None] + rows[r1] * t[:, None, None]  # (n, 3, 5)
    weight = np.sin(theta) * (half * node_weights).reshape(-1)
    # Each harmonic is (its latitude part at phi = 0 or pi / 4, scaled) times one longitude mode: 1, sin phi, cos phi,
    # sin 2 phi, cos 2 phi. Its latitude part is read off _basis at a longitude where the mode is 1.
    mode_of = (0, 1, 0, 2, 1, 2, 3, 0, 4)
    at = {0: 0.0, 1: np.pi / 2, 2: 0.0, 3: np.pi / 4, 4: 0.0}
    out = np.zeros((9, 3))
    for k in range(9):
        m = mode_of[k]
        latitude = _basis(theta, np.full(n, at[m]))[k]
        out[k] = np.einsum("n,nc->c", latitude * weight, filtered[:, :, m])
    return out
