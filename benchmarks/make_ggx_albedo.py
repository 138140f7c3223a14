"""Writes ``wrt/data/ggx_albedo.npy``: the directional albedo of wrt's GGX lobe, for the multiple-scattering
compensation of :mod:`wrt.microfacet_albedo` (Kulla and Conty 2017).

The table is stored rather than computed when wrt is imported: a quadrature accurate to about 1e-4 takes a few
minutes in numpy (the horizon cuts the sample space along a curve, so a midpoint grid converges slowly), and loading
24 KB takes a millisecond. It is deterministic (a midpoint grid, no random numbers); its rows and columns are
``wrt.microfacet_albedo.table_roughness`` and ``table_cosines`` (dense at low roughness and grazing views, where a
smooth lobe's albedo dips at a viewing cosine of about alpha). Run this script again after a change to the GGX lobe
in ``wrt/bsdf.py`` (distribution, Smith term, ``MIN_ALPHA``) or to those axes. ``tests/test_microfacet_albedo.py``
recomputes some rows with :func:`vndf_albedo` and fails when the file and this script disagree, and checks the
lookups against an independent float64 quadrature.

Usage: ``python benchmarks/make_ggx_albedo.py [--grid 512]``.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from wrt.microfacet_albedo import table_cosines, table_roughness  # noqa: E402

OUT = ROOT / "wrt" / "data" / "ggx_albedo.npy"
N_ROUGHNESS = 48  # table rows: perceptual roughness table_roughness(48), 0.02 to 1 (GGX alpha = roughness^2)
N_MU = 64  # table columns: cosine of the viewing angle table_cosines(64) = (j / 63)^4, dense at grazing angles
MIN_ALPHA = 4.0e-4  # wrt.bsdf.MIN_ALPHA
MIN_MU = 1.0e-9  # the column mu = 0 is taken at this cosine (E there is within 1e-5 of its limit 1 at mu = 0)
MU_CHUNK = 8  # cosines integrated at once (a 512 x 512 grid per cosine: 2 MB per array)


def smith_lambda(cos_t, alpha):
    """Smith's ``Lambda`` for GGX, ``(sqrt(cos^2 + alpha^2 sin^2) / cos - 1) / 2`` (``wrt.bsdf.ggx_masking_length``
    is ``cos_t (1 + 2 Lambda)``), without the tangent, whose square was clamped at a cosine of 1e-6."""
    c2 = cos_t * cos_t
    return 0.5 * (np.sqrt(c2 + alpha * alpha * np.maximum(1.0 - c2, 0.0)) / cos_t - 1.0)


def vndf_albedo(roughness, mu, grid: int) -> np.ndarray:
    """``(..., 2)`` float64: ``E``, the albedo of a white GGX lobe (``F = 1``, ``f = D G2 / (4 cos_o cos_i)``), and
    ``B``, the part of it weighted by ``(1 - cos_vh)^5``, for a viewer at ``cos_o = mu``.

    Integrated over the distribution of visible normals (Heitz 2018, the warp ``wrt.bsdf.sample_ggx_vndf`` uses), in
    which a reflected direction's weight is ``G2 / G1(wo)``, by the midpoint rule on a ``grid x grid`` square.
    ``roughness`` and ``mu`` broadcast against each other.
    """
    roughness, mu = np.broadcast_arrays(np.asarray(roughness, np.float64), np.asarray(mu, np.float64))
    alpha = np.maximum(roughness * roughness, MIN_ALPHA)[..., None]
    mu = np.clip(mu, MIN_MU, 1.0)[..., None]
    u = (np.arange(grid) + 0.5) / grid
    u1, u2 = (x.ravel() for x in np.meshgrid(u, u, indexing="ij"))
    # Stretch the view to the hemisphere configuration (wo in the xz plane), sample a visible normal, unstretch.
    sin_o = np.sqrt(1.0 - mu * mu)
    vh = np.stack(np.broadcast_arrays(alpha * sin_o, 0.0 * mu, mu), -1)
    vh /= np.linalg.norm(vh, axis=-1, keepdims=True)
    r = np.sqrt(u1)
    p1 = r * np.cos(2.0 * np.pi * u2)
    p2 = r * np.sin(2.0 * np.pi * u2)
    s = 0.5 * (1.0 + vh[..., 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    # The tangent t1 is +y for a view in the xz plane; t2 = vh x t1.
    hx = p2 * (-vh[..., 2]) + p3 * vh[..., 0]
    hy = p1
    hz = p2 * vh[..., 0] + p3 * vh[..., 2]
    h = np.stack([alpha * hx, alpha * hy, np.maximum(1e-6, hz)], -1)
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    cos_vh = sin_o * h[..., 0] + mu * h[..., 2]
    mu_i = 2.0 * cos_vh * h[..., 2] - mu
    lam_o = smith_lambda(mu, alpha)
    weight = np.where(mu_i > 0.0, (1.0 + lam_o) / (1.0 + lam_o + smith_lambda(np.maximum(mu_i, 1e-300), alpha)), 0.0)
    e = weight.mean(-1)
    b = (weight * np.clip(1.0 - cos_vh, 0.0, 1.0) ** 5).mean(-1)
    return np.stack([e, b], -1)


def make_table(grid: int) -> np.ndarray:
    """``(N_ROUGHNESS, N_MU, 2)`` float32 :func:`vndf_albedo` at the table's nodes, a few cosines at a time."""
    mu = table_cosines(N_MU)
    rows = [np.concatenate([vndf_albedo(r, mu[k:k + MU_CHUNK], grid) for k in range(0, N_MU, MU_CHUNK)])
            for r in table_roughness(N_ROUGHNESS)]
    return np.stack(rows).astype(np.float32)


def main():
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--grid", type=int, default=512, help="midpoint grid per side in the sample square")
    parser.add_argument("-o", "--out", type=Path, default=OUT)
    args = parser.parse_args()
    table = make_table(args.grid)
    np.save(args.out, table)
    print(f"wrote {args.out}: {table.shape}, E from {table[..., 0].min():.4f} to {table[..., 0].max():.4f}")


if __name__ == "__main__":
    main()
