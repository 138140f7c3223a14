"""A float64 quadrature of the directional albedo of a white GGX lobe, written from the microfacet model itself
(not from ``benchmarks/make_ggx_albedo.py``), as the oracle of the albedo tables' tests.

For a viewer at ``mu = cos theta_o`` the white lobe ``f = D G2 / (4 cos_o cos_i)`` reflects ``E = int D(h) G2 (wo.h)
/ cos_o dw_h`` (``dw_i = 4 (wo.h) dw_h``). In GGX's slope space, scaled by alpha (``h ~ (-alpha u, -alpha v, 1)``),
``D(h) cos_h dw_h = du dv / (pi (1 + u^2 + v^2)^2)``, which ``s = r^2 / (1 + r^2)`` and the azimuth ``phi`` make
uniform on ``[0, 1) x [0, 2 pi)``. The reflected direction lies above the horizon exactly where ``alpha r cos phi <
cos_o (1 - alpha^2 r^2) / (2 sin_o)`` (which also keeps ``wo.h > 0``), so the integrand is smooth inside a region
whose boundary is known in closed form: Gauss-Legendre in ``phi`` up to that boundary, and in ``s`` on the pieces
between the radii where the boundary appears (``phi`` cut at all) and where it closes (nothing left), with a
substitution that clusters nodes at the pieces' ends (where the inner integral has square-root corners). Accurate
to about 1e-9 at 2 x 200 nodes (checked by doubling them).
"""

import numpy as np


def smith_lambda(cos_t, alpha):
    """Smith's ``Lambda`` of GGX, ``(sqrt(1 + alpha^2 tan^2) - 1) / 2``, written without the tangent."""
    c2 = cos_t * cos_t
    return 0.5 * (np.sqrt(c2 + alpha * alpha * (1.0 - c2)) / cos_t - 1.0)


def _clustered_nodes(a, b, nodes):
    """Gauss-Legendre nodes and weights on ``[a, b]`` through ``x = a + (b - a) (3t^2 - 2t^3)`` (dense at both ends)."""
    t, w = np.polynomial.legendre.leggauss(nodes)
    t = 0.5 * (t + 1.0)
    w = 0.5 * w
    x = a + (b - a) * (3.0 * t * t - 2.0 * t ** 3)
    return x, w * (b - a) * 6.0 * t * (1.0 - t)


def ggx_albedo(alpha: float, mu: float, nodes: int = 200) -> tuple[float, float]:
    """``(E, B)`` float64 of a white GGX lobe (height-correlated Smith ``G2``) of ``alpha`` seen at ``mu > 0``: its
    albedo, and the part of it weighted by ``(1 - wo.h)^5`` (Schlick's grazing term)."""
    sin_o = np.sqrt(max(1.0 - mu * mu, 0.0))
    # The slope radius (unscaled) below which no azimuth is cut, and above which every one is.
    r_open = (1.0 - sin_o) / mu
    r_shut = (1.0 + sin_o) / mu
    s_of = lambda r: (r / alpha) ** 2 / (1.0 + (r / alpha) ** 2)  # noqa: E731
    lam_o = smith_lambda(mu, alpha)
    e_sum = b_sum = 0.0
    for s_lo, s_hi in ((0.0, s_of(r_open)), (s_of(r_open), s_of(r_shut))):
        if s_hi <= s_lo:
            continue
        s, ws = _clustered_nodes(s_lo, s_hi, nodes)
        r = alpha * np.sqrt(s / (1.0 - s))  # slope radius
        bound = mu * (1.0 - r * r) / (2.0 * sin_o * np.maximum(r, 1e-300)) if sin_o > 0.0 else np.full_like(r, 2.0)
        phi0 = np.arccos(np.clip(bound, -1.0, 1.0))  # azimuths |phi| < phi0 reflect below the horizon
        t, wt = np.polynomial.legendre.leggauss(nodes)
        # phi from phi0 to pi (the other half is its mirror image).
        phi = phi0[:, None] + (np.pi - phi0[:, None]) * 0.5 * (t[None, :] + 1.0)
        wphi = (np.pi - phi0[:, None]) * 0.5 * wt[None, :]
        x = r[:, None] * np.cos(phi)
        y = r[:, None] * np.sin(phi)
        norm = np.sqrt(1.0 + x * x + y * y)
        cos_oh = (mu - x * sin_o) / norm  # h = (-x, -y, 1) / norm, wo = (sin_o, 0, mu)
        cos_h = 1.0 / norm
        cos_i = np.maximum(2.0 * cos_oh * cos_h - mu, 1e-300)
        g2 = 1.0 / (1.0 + lam_o + smith_lambda(cos_i, alpha))
        value = g2 * cos_oh / (mu * cos_h)
        weight = ws[:, None] * wphi / np.pi  # ds dphi / (2 pi), both halves
        e_sum += float((value * weight).sum())
        b_sum += float((value * np.clip(1.0 - cos_oh, 0.0, 1.0) ** 5 * weight).sum())
    return e_sum, b_sum
