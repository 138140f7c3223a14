"""Directional albedo of wrt's GGX lobe as device tables, for multiple-scattering energy compensation.

A single-scattering microfacet lobe loses the light that bounces between microfacets more than once: a white GGX
metal reflects ``E(mu, alpha) < 1`` of the light arriving from ``mu = cos theta`` (0.41 on average at roughness 1).
Kulla and Conty ("Revisiting Physically Based Shading at Imageworks", SIGGRAPH 2017 course) add a lobe
``f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg))`` with ``E_avg = 2 int_0^1 E(mu) mu dmu``, which reflects
exactly the missing ``1 - E(mu_o)``; :mod:`wrt.bsdf` weights it with a Fresnel colour and uses the albedo of its
specular lobes to scale the layers below them.

The table ``wrt/data/ggx_albedo.npy`` holds ``E`` and ``B`` (the part of ``E`` weighted by ``(1 - cos_vh)^5``, so
that a Schlick lobe of ``F0, F90`` reflects ``F0 (E - B) + F90 B``) on axes dense where ``E`` changes fast: rows at
perceptual roughness ``0.02 + 0.03 ((1 + 0.98 / 0.03)^x - 1)`` for ``x = k / (R - 1)`` (:func:`table_roughness`:
nearly even in ``log alpha`` below roughness 0.1, nearly even in roughness above 0.3), columns at ``mu = (j / (M -
1))^4`` (:func:`table_cosines`). A smooth lobe's ``E`` dips at ``mu`` of about ``alpha`` (to 0.89 at roughness 0.03
and ``mu`` 0.001) and is 1 again at ``mu = 0``, a dip that 32 rows even in roughness and 32 columns at ``(j /
31)^2`` did not resolve: the lookups were off by up to 4% below ``mu`` 0.01 (a white metal of roughness 0.05
reflected 1.023 at ``mu`` 1e-4). Within 2.5e-3 of a float64 quadrature at 48 x 64 (``tests/ggx_albedo_oracle.py``).
It is made by ``benchmarks/make_ggx_albedo.py`` (a few minutes of quadrature, hence stored; loading it takes about a
millisecond). Lookups are bilinear in ``(x, mu^(1/4))``; ``1 - E_avg`` is the average loss of that interpolant
(stored as the loss: for smooth lobes ``E_avg`` is within 1e-5 of 1, where float32 keeps few digits of the
difference), so the added lobe restores what the interpolated ``E`` says is missing.

The compensation lobe is importance-sampled from the same table: its directions are drawn with a density
proportional to ``c_j mu_i`` in column interval ``j`` (azimuth uniform), ``c_j`` the larger of ``1 - E`` at the
interval's two columns, so that ``f_ms cos_i / pdf = F_ms (1 - E(mu_o)) (1 - E(mu_i)) / c_j * C / (1 - E_avg)`` (``C``
the density's normalisation) stays within ``F_ms (1 - E(mu_o))`` times 1.5 (at roughness 0.02; 1.24 at 0.03, 1.14
from 0.065 up, with the 48 x 64 table). At low roughness ``1 - E`` lives in a narrow band of grazing directions,
which cosine-weighted sampling rarely hits, and weighs ``(1 - E(mu_i)) / (1 - E_avg)`` there: up to 19000 at
roughness 0.03, 1500 at 0.065, 110 at 0.13. The densities ``c`` and their cumulative sums over ``mu^2`` are
derived from the stored ``E`` when the table is loaded (as ``1 - E_avg`` is), so the sampler always follows the lobe
that is evaluated.
"""

import functools
from pathlib import Path

import numpy as np
import warp as wp

from .sampling import PI

TABLE_PATH = Path(__file__).parent / "data" / "ggx_albedo.npy"  # written by benchmarks/make_ggx_albedo.py
LOSS_ROUNDING = 2.0**-22  # float32 rounding of 1 - E looked up near E = 1 (4 ulps below 1): the f_ms density floor
FIRST_ROUGHNESS = wp.constant(0.02)  # roughness of row 0: wrt.bsdf.DELTA_ROUGHNESS (a mirror below, never looked up)
ROUGHNESS_KNEE = wp.constant(0.03)  # rows even in log(roughness - FIRST_ROUGHNESS + knee): log below it, linear above
ROUGHNESS_SPAN = wp.constant(float(np.log1p((1.0 - FIRST_ROUGHNESS) / ROUGHNESS_KNEE)))  # that log's range up to 1


def table_roughness(rows: int) -> np.ndarray:
    """``(rows,)`` float64 perceptual roughness of the table's rows, 0.02 to 1 (inverse of :func:`roughness_row`)."""
    x = np.linspace(0.0, 1.0, rows)
    return FIRST_ROUGHNESS + ROUGHNESS_KNEE * np.expm1(x * ROUGHNESS_SPAN)


def table_cosines(cols: int) -> np.ndarray:
    """``(cols,)`` float64 viewing cosines ``mu = (j / (cols - 1))^4`` of the table's columns, 0 to 1."""
    return np.linspace(0.0, 1.0, cols) ** 4


@wp.struct
class GgxAlbedo:
    """The albedo tables on one device."""

    albedo: wp.array2d[wp.vec2]  # (R, M) E and B at roughness table_roughness(R)[k], mu = (j / (M - 1))^4
    average_loss: wp.array[float]  # (R,) 1 - E_avg of row k
    ms_density: wp.array2d[float]  # (R, M - 1) the f_ms sampling density's c_j >= 1 - E over column interval j
    ms_cdf: wp.array2d[float]  # (R, M) sum of c_j' (mu_{j'+1}^2 - mu_j'^2) over the intervals j' < j


def average_loss(albedo: np.ndarray, samples: int = 4097) -> np.ndarray:
    """``(R,)`` float64 ``1 - E_avg = 2 int_0^1 (1 - E(mu)) mu dmu`` of each row of ``albedo`` (``(R, M)``, columns
    at :func:`table_cosines`), interpolated linearly in ``mu^(1/4)`` as the lookups do (trapezoid rule on ``samples``
    points: within 1e-8)."""
    nodes = np.linspace(0.0, 1.0, albedo.shape[1])
    s = np.linspace(0.0, 1.0, samples)
    mu = s**4
    y = 2.0 * (1.0 - np.stack([np.interp(s, nodes, row) for row in albedo])) * mu
    return 0.5 * ((y[:, 1:] + y[:, :-1]) * np.diff(mu)).sum(axis=1)


def multiple_scattering_sampling(albedo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sampling tables of the compensation lobe for ``albedo`` (``(R, M)`` E, columns at :func:`table_cosines`):
    ``(R, M - 1)`` float64 ``c_j``, the larger of ``1 - E`` at columns ``j`` and ``j + 1`` (so at least the linear
    interpolant of ``1 - E`` inside the interval) plus :data:`LOSS_ROUNDING`, and ``(R, M)`` their
    cumulative integral over ``mu^2``. Directions drawn with density ``c_j mu`` per interval make ``f_ms cos / pdf``
    nearly constant. The floor keeps it so where a smooth lobe's ``E`` is within a few float32 ulps of 1, whose
    lookups' rounding made ``1 - E`` up to 3.4 times ``c`` (roughness 0.03, ``mu`` 0.9); it adds 3% to the
    density's integral at roughness 0.03, less above, and keeps every ``c_j`` above 0."""
    loss = np.maximum(1.0 - albedo, 0.0)
    density = np.maximum(loss[:, :-1], loss[:, 1:]) + LOSS_ROUNDING
    mu2 = table_cosines(albedo.shape[1]) ** 2
    cdf = np.concatenate([np.zeros((len(albedo), 1)), np.cumsum(density * np.diff(mu2), axis=1)], axis=1)
    return density, cdf


@functools.cache
def load_table() -> np.ndarray:
    """``(R, M, 2)`` float32 ``E, B`` from :data:`TABLE_PATH`."""
    table = np.load(TABLE_PATH)
    if table.ndim != 3 or table.shape[2] != 2 or min(table.shape[:2]) < 2 or not np.isfinite(table).all():
        raise ValueError(f"{TABLE_PATH}: expected finite (R, M, 2) GGX albedo values, got {table.shape}; "
                         "run benchmarks/make_ggx_albedo.py")
    return table


@functools.cache
def _tables_on(device: str) -> GgxAlbedo:
    table = load_table()
    t = GgxAlbedo()
    t.albedo = wp.array(table, dtype=wp.vec2, device=device)
    loss = average_loss(table[..., 0].astype(np.float64)).astype(np.float32)
    t.average_loss = wp.array(loss, dtype=float, device=device)
    density, cdf = multiple_scattering_sampling(table[..., 0].astype(np.float64))
    t.ms_density = wp.array(density.astype(np.float32), dtype=float, device=device)
    t.ms_cdf = wp.array(cdf.astype(np.float32), dtype=float, device=device)
    return t


def ggx_albedo_tables(device=None) -> GgxAlbedo:
    """The tables on ``device`` (Warp's default device for ``None``), uploaded once per device and process."""
    return _tables_on(wp.get_device(device).alias)  # Warp's devices are not hashable; their aliases are


@wp.func
def roughness_row(rows: int, roughness: float):
    """Table row ``i`` below ``roughness`` and the weight ``fx`` of row ``i + 1`` in the linear interpolation, in the
    rows' coordinate ``log(1 + (roughness - 0.02) / 0.03)`` (:func:`table_roughness`); roughness below 0.02 (a mirror,
    never looked up by the BSDF) reads row 0."""
    r = wp.clamp(roughness, FIRST_ROUGHNESS, 1.0)
    x = wp.log(1.0 + (r - FIRST_ROUGHNESS) / ROUGHNESS_KNEE) * (float(rows - 1) / ROUGHNESS_SPAN)
    i = wp.min(int(x), rows - 2)
    return i, x - float(i)


@wp.func
def cosine_column(cols: int, mu: float):
    """Table column ``j`` below ``mu`` and the weight ``fy`` of column ``j + 1``, linear in ``mu^(1/4)``."""
    y = wp.sqrt(wp.sqrt(wp.clamp(mu, 0.0, 1.0))) * float(cols - 1)
    j = wp.min(int(y), cols - 2)
    return j, y - float(j)


@wp.func
def lookup_ggx_albedo(t: GgxAlbedo, roughness: float, mu: float):
    """``(E, B)`` of a lobe of perceptual ``roughness`` for a viewer at ``mu = cos theta``, bilinear."""
    i, fx = roughness_row(t.albedo.shape[0], roughness)
    j, fy = cosine_column(t.albedo.shape[1], mu)
    lower = wp.lerp(t.albedo[i, j], t.albedo[i, j + 1], fy)
    upper = wp.lerp(t.albedo[i + 1, j], t.albedo[i + 1, j + 1], fy)
    return wp.lerp(lower, upper, fx)


@wp.func
def lookup_ggx_average_loss(t: GgxAlbedo, roughness: float):
    """``1 - E_avg`` of a lobe of perceptual ``roughness``, linear between the table's rows."""
    i, fx = roughness_row(t.average_loss.shape[0], roughness)
    return wp.lerp(t.average_loss[i], t.average_loss[i + 1], fx)


@wp.func
def lookup_multiple_scattering_total(t: GgxAlbedo, roughness: float):
    """``C``, the integral over ``mu^2`` of the compensation lobe's sampling density for a lobe of perceptual
    ``roughness`` (linear between the table's rows): the ``total`` that :func:`sample_multiple_scattering_cos` and
    :func:`multiple_scattering_pdf` take, looked up once per shading point."""
    i, fx = roughness_row(t.ms_cdf.shape[0], roughness)
    cols = t.ms_cdf.shape[1]
    return wp.lerp(t.ms_cdf[i, cols - 1], t.ms_cdf[i + 1, cols - 1], fx)


@wp.func
def sample_multiple_scattering_cos(t: GgxAlbedo, roughness: float, total: float, u: float):
    """``mu_i = cos theta_i`` of a direction drawn for the compensation lobe of a lobe of perceptual ``roughness``
    from a uniform ``u`` (the azimuth is uniform): density ``c_j mu`` over column interval ``j``, the rows' ``c``
    interpolated linearly in roughness as ``E`` is; ``total`` is its integral
    (:func:`lookup_multiple_scattering_total`); :func:`multiple_scattering_pdf` is its solid-angle pdf."""
    i, fx = roughness_row(t.ms_cdf.shape[0], roughness)
    cols = t.ms_cdf.shape[1]
    target = u * total
    # Find the last interval j whose cumulative integral below it is at most the target (binary search).
    lo = int(0)
    hi = cols - 2
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if wp.lerp(t.ms_cdf[i, mid], t.ms_cdf[i + 1, mid], fx) <= target:
            lo = mid
        else:
            hi = mid - 1
    # Invert the linear integral of the constant density over mu^2 inside it (c >= LOSS_ROUNDING > 0); the columns'
    # mu^2 are (j / (cols - 1))^8.
    s0 = float(lo) / float(cols - 1)
    s1 = float(lo + 1) / float(cols - 1)
    v0 = s0 * s0 * s0 * s0
    v0 = v0 * v0
    v1 = s1 * s1 * s1 * s1
    v1 = v1 * v1
    c = wp.lerp(t.ms_density[i, lo], t.ms_density[i + 1, lo], fx)
    return wp.sqrt(wp.clamp(v0 + (target - wp.lerp(t.ms_cdf[i, lo], t.ms_cdf[i + 1, lo], fx)) / c, v0, v1))


@wp.func
def multiple_scattering_pdf(t: GgxAlbedo, roughness: float, total: float, mu: float):
    """Solid-angle pdf of a direction at ``mu = cos theta`` drawn by :func:`sample_multiple_scattering_cos` (with a
    uniform azimuth): ``c_j mu / (pi C)``, ``C = total`` the density's integral over ``mu^2``
    (:func:`lookup_multiple_scattering_total`)."""
    if mu <= 0.0:
        return 0.0
    i, fx = roughness_row(t.ms_cdf.shape[0], roughness)
    j, fy = cosine_column(t.ms_cdf.shape[1], mu)
    return wp.lerp(t.ms_density[i, j], t.ms_density[i + 1, j], fx) * mu / (PI * total)
