"""An oracle for UsdLux lights independent of wrt: irradiance at points of the z = 0 plane (normal +Z) by midpoint
quadrature over a light's surface or cone of directions, and the colour of a blackbody from Planck's law."""

from __future__ import annotations

import math

import numpy as np


def polygon_irradiance(p, n, corners, radiance) -> float:
    """Lambert's closed form: irradiance at ``p`` (unit normal ``n``) from uniform polygons of ``radiance`` wholly
    above its horizon, ``corners`` ``(T, k, 3)`` (or one polygon ``(k, 3)``): per polygon ``L / 2 * |sum(edge angle
    * (n . unit normal of the edge's plane through p))|``, summed (each polygon counts positive, whatever its
    winding)."""
    v = np.asarray(corners, np.float64).reshape(-1, np.shape(corners)[-2], 3) - np.asarray(p, np.float64)
    w = np.roll(v, -1, axis=1)
    cross = np.cross(v, w)
    length = np.linalg.norm(cross, axis=-1)
    angle = np.arctan2(length, np.sum(v * w, axis=-1))
    return float(radiance / 2.0 * np.abs(np.sum(angle * (cross @ np.asarray(n, np.float64)) / length, axis=1)).sum())


def trs(translate=(0, 0, 0), rotate_xyz=(0, 0, 0), scale=(1, 1, 1)) -> np.ndarray:
    """Column-vector 4x4 of USD's ``translate, rotateXYZ, scale`` op order (X rotated first, then Y, then Z)."""
    ax, ay, az = np.radians(rotate_xyz)
    rx = np.array([[1, 0, 0], [0, math.cos(ax), -math.sin(ax)], [0, math.sin(ax), math.cos(ax)]])
    ry = np.array([[math.cos(ay), 0, math.sin(ay)], [0, 1, 0], [-math.sin(ay), 0, math.cos(ay)]])
    rz = np.array([[math.cos(az), -math.sin(az), 0], [math.sin(az), math.cos(az), 0], [0, 0, 1]])
    m = np.eye(4)
    m[:3, :3] = rz @ ry @ rx @ np.diag(scale)
    m[:3, 3] = translate
    return m


def _midpoints(lo, hi, n):
    return lo + (np.arange(n) + 0.5) / n * (hi - lo)


def _surface(m, local, d_local_du, d_local_dv, local_normal, du_dv):
    """World points, unit emitting normals (the inverse transpose carries normals) and areas of surface elements."""
    m3 = m[:3, :3]
    points = local @ m3.T + m[:3, 3]
    areas = np.linalg.norm(np.cross(d_local_du @ m3.T, d_local_dv @ m3.T), axis=-1) * du_dv
    normals = local_normal @ np.linalg.inv(m3)
    return points, normals / np.linalg.norm(normals, axis=-1, keepdims=True), areas


def rect(m, width, height, n=160):
    grid = np.meshgrid(_midpoints(-width / 2, width / 2, n), _midpoints(-height / 2, height / 2, n))
    u, v = (g.ravel() for g in grid)
    local = np.stack([u, v, 0 * u], -1)
    ones = np.ones_like(u)
    return _surface(m, local, np.stack([ones, 0 * u, 0 * u], -1), np.stack([0 * u, ones, 0 * u], -1),
                    np.stack([0 * u, 0 * u, -ones], -1), width * height / n**2)


def disk(m, radius, n=160):
    r, a = (g.ravel() for g in np.meshgrid(_midpoints(0, radius, n), _midpoints(0, 2 * np.pi, 2 * n)))
    local = np.stack([r * np.cos(a), r * np.sin(a), 0 * r], -1)
    return _surface(m, local, np.stack([np.cos(a), np.sin(a), 0 * r], -1),
                    np.stack([-r * np.sin(a), r * np.cos(a), 0 * r], -1),
                    np.stack([0 * r, 0 * r, -np.ones_like(r)], -1), (radius / n) * (np.pi / n))


def sphere(m, radius, n=120):
    c, a = (g.ravel() for g in np.meshgrid(_midpoints(-1, 1, n), _midpoints(0, 2 * np.pi, 2 * n)))
    s = np.sqrt(1 - c * c)
    unit = np.stack([s * np.cos(a), s * np.sin(a), c], -1)
    # d/dc and d/da of radius * unit span an area radius^2 dc da (Archimedes' hat-box).
    d_dc = radius * np.stack([-c / s * np.cos(a), -c / s * np.sin(a), np.ones_like(c)], -1)
    d_da = radius * np.stack([-s * np.sin(a), s * np.cos(a), 0 * c], -1)
    return _surface(m, radius * unit, d_dc, d_da, unit, (2 / n) * (np.pi / n))


def cylinder(m, length, radius, n=160):
    x, a = (g.ravel() for g in np.meshgrid(_midpoints(-length / 2, length / 2, n), _midpoints(0, 2 * np.pi, 2 * n)))
    around = np.stack([0 * x, np.cos(a), np.sin(a)], -1)
    return _surface(m, radius * around + np.stack([x, 0 * x, 0 * x], -1), np.stack([np.ones_like(x), 0 * x, 0 * x], -1),
                    radius * np.stack([0 * x, -np.sin(a), np.cos(a)], -1), around, (length / n) * (np.pi / n))


def irradiance(points, elements, radiance=1.0, shaping=None, axis=None):
    """Irradiance at ``points`` ``(P, 3)`` of the z = 0 plane from Lambertian surface ``elements`` of ``radiance``;
    ``shaping(theta)`` scales light leaving at angle theta to unit ``axis``."""
    q, n, area = elements
    to = q[None] - points[:, None]
    d2 = (to**2).sum(-1)
    d = np.sqrt(d2)
    weight = np.clip(to[..., 2] / d, 0, None) * np.clip(-(to * n[None]).sum(-1) / d, 0, None) * area / d2
    if shaping is not None:
        weight = weight * shaping(np.arccos(np.clip(-(to / d[..., None]) @ axis, -1, 1)))
    return weight.sum(-1) * radiance


def cone_irradiance(to_light, angle_deg, radiance, n=300):
    """Irradiance on the z = 0 plane from a disc of directions of angular diameter ``angle_deg`` about ``to_light``."""
    a = np.asarray(to_light, float) / np.linalg.norm(to_light)
    t1 = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(a, t1)
    cos_half = math.cos(math.radians(angle_deg) / 2)
    c, p = (g.ravel() for g in np.meshgrid(_midpoints(cos_half, 1, n), _midpoints(0, 2 * np.pi, n)))
    s = np.sqrt(1 - c * c)
    z = c * a[2] + s * np.cos(p) * t1[2] + s * np.sin(p) * t2[2]
    return np.clip(z, 0, None).sum() * 2 * np.pi * (1 - cos_half) / c.size * radiance


def _lobe(x, mu, below, above):
    return np.exp(-0.5 * ((x - mu) / np.where(x < mu, below, above)) ** 2)


def blackbody_rgb(kelvin: float) -> np.ndarray:
    """Linear Rec.709 colour of a blackbody of luminance 1: Planck's law times the CIE 1931 2-degree observer (the
    multi-lobe Gaussian fit of Wyman, Sloan and Shirley 2013, within about 1% of the tables)."""
    lam = np.arange(360.0, 831.0)
    xbar = 1.056 * _lobe(lam, 599.8, 37.9, 31.0) + 0.362 * _lobe(lam, 442.0, 16.0, 26.7) \
        - 0.065 * _lobe(lam, 501.1, 20.4, 26.2)
    ybar = 0.821 * _lobe(lam, 568.8, 46.9, 40.5) + 0.286 * _lobe(lam, 530.9, 16.3, 31.1)
    zbar = 1.217 * _lobe(lam, 437.0, 11.8, 36.0) + 0.681 * _lobe(lam, 459.0, 26.0, 13.8)
    metres = lam * 1e-9
    planck = 1.0 / (metres**5 * np.expm1(1.4387769e-2 / (metres * kelvin)))
    xyz = np.array([(xbar * planck).sum(), (ybar * planck).sum(), (zbar * planck).sum()])
    rgb = np.array([[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560],
                    [0.0556434, -0.2040259, 1.0572252]]) @ xyz
    return rgb / (np.array([0.2126, 0.7152, 0.0722]) @ rgb)
