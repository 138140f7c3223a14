"""Directional albedo of wrt's GGX lobe as device tables, for multiple-scattering energy compensation.

A single-scattering microfacet lobe loses the light that bounces between microfacets more than once: a white GGX
metal reflects ``E(mu, alpha) < 1`` of the light arriving from ``mu = cos theta`` (0.41 on average at roughness 1).
Kulla and Conty ("Revisiting Physically Based Shading at Imageworks", SIGGRAPH 2017 course) add a lobe
``f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg))`` with ``E_avg = 2 int_0^1 E(mu) mu dmu``, which reflects
exactly the missing ``1 - E(mu_o)``; :mod:`wrt.bsdf` weights it with a Fresnel colour and uses the albedo of its
specular lobes to scale the layers below them.

The table ``wrt/data/ggx_albedo.npy`` holds ``E`` and ``B`` (the part of ``E`` weighted by ``(1 - cos_vh)^5``, so
that a Schlick lobe of ``F0, F90`` reflects ``F0 (E - B) + F90 B``) at perceptual roughness ``k / 31`` (rows) and
``mu = (j / 31)^2`` (columns, dense at grazing angles, where ``E`` of a smooth lobe dips). It is made by
``benchmarks/make_ggx_albedo.py`` (a one-minute quadrature, hence stored; loading it takes about a millisecond). Lookups
are bilinear in ``(roughness, sqrt(mu))``; ``1 - E_avg`` is the average loss of that interpolant (stored as the loss:
for smooth lobes ``E_avg`` is within 1e-5 of 1, where float32 keeps few digits of the difference), so the added lobe
restores what the interpolated ``E`` says is missing.
"""

import functools
from pathlib import Path

import numpy as np
import warp as wp

TABLE_PATH = Path(__file__).parent / "data" / "ggx_albedo.npy"  # written by benchmarks/make_ggx_albedo.py


@wp.struct
class GgxAlbedo:
    """The albedo tables on one device."""

    albedo: wp.array2d[wp.vec2]  # (R, M) E and B at roughness k / (R - 1), mu = (j / (M - 1))^2
    average_loss: wp.array[float]  # (R,) 1 - E_avg at roughness k / (R - 1)


def average_loss(albedo: np.ndarray, samples: int = 4097) -> np.ndarray:
    """``(R,)`` float64 ``1 - E_avg = 2 int_0^1 (1 - E(mu)) mu dmu`` of each row of ``albedo`` (``(R, M)``, columns
    at ``mu = (j / (M - 1))^2``), interpolated linearly in ``sqrt(mu)`` as the lookups do (trapezoid rule on
    ``samples`` points: within 1e-8)."""
    nodes = np.linspace(0.0, 1.0, albedo.shape[1])
    s = np.linspace(0.0, 1.0, samples)
    mu = s * s
    y = 2.0 * (1.0 - np.stack([np.interp(s, nodes, row) for row in albedo])) * mu
    return 0.5 * ((y[:, 1:] + y[:, :-1]) * np.diff(mu)).sum(axis=1)


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
    return t


def ggx_albedo_tables(device=None) -> GgxAlbedo:
    """The tables on ``device`` (Warp's default device for ``None``), uploaded once per device and process."""
    return _tables_on(wp.get_device(device).alias)  # Warp's devices are not hashable; their aliases are


@wp.func
def lookup_ggx_albedo(t: GgxAlbedo, roughness: float, mu: float):
    """``(E, B)`` of a lobe of perceptual ``roughness`` for a viewer at ``mu = cos theta``, bilinear."""
    rows = t.albedo.shape[0]
    cols = t.albedo.shape[1]
    x = wp.clamp(roughness, 0.0, 1.0) * float(rows - 1)
    y = wp.sqrt(wp.clamp(mu, 0.0, 1.0)) * float(cols - 1)
    i = wp.min(int(x), rows - 2)
    j = wp.min(int(y), cols - 2)
    fx = x - float(i)
    fy = y - float(j)
    lower = wp.lerp(t.albedo[i, j], t.albedo[i, j + 1], fy)
    upper = wp.lerp(t.albedo[i + 1, j], t.albedo[i + 1, j + 1], fy)
    return wp.lerp(lower, upper, fx)


@wp.func
def lookup_ggx_average_loss(t: GgxAlbedo, roughness: float):
    """``1 - E_avg`` of a lobe of perceptual ``roughness``, linear between the table's rows."""
    rows = t.average_loss.shape[0]
    x = wp.clamp(roughness, 0.0, 1.0) * float(rows - 1)
    i = wp.min(int(x), rows - 2)
    return wp.lerp(t.average_loss[i], t.average_loss[i + 1], x - float(i))
