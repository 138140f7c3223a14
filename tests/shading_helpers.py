"""Small scenes for the shading tests, built in Python (no USD): planes, tessellated spheres, cameras."""

from __future__ import annotations

import numpy as np

import wrt


def quad(center, u, v, name="/quad", material=None, double_sided=True, normal_side=None) -> wrt.Mesh:
    """A rectangle ``center +- u/2 +- v/2`` as two triangles wound so ``cross(u, v)`` is its front."""
    c, u, v = (np.asarray(x, np.float64) for x in (center, u, v))
    points = [c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2]
    indices = [[0, 1, 2], [0, 2, 3]]
    ids = None if material is None else np.full(2, material, np.int32)
    return wrt.Mesh(name, points, indices, [0, 0], double_sided=double_sided, material_ids=ids)


def uv_sphere(center=(0, 0, 0), radius=1.0, rings=48, segments=96, name="/sphere", material=None, smooth=False):
    """A closed tessellated sphere, wound counter-clockwise seen from outside (front faces outwards)."""
    points = [(0.0, 0.0, 1.0)]
    for i in range(1, rings):
        theta = np.pi * i / rings
        for j in range(segments):
            phi = 2 * np.pi * j / segments
            points.append((np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)))
    points.append((0.0, 0.0, -1.0))
    unit = np.asarray(points, np.float64)
    last = len(unit) - 1
    tris = []
    for j in range(segments):
        tris.append([0, 1 + j, 1 + (j + 1) % segments])
    for i in range(rings - 2):
        a0, b0 = 1 + i * segments, 1 + (i + 1) * segments
        for j in range(segments):
            j1 = (j + 1) % segments
            tris.append([a0 + j, b0 + j, b0 + j1])
            tris.append([a0 + j, b0 + j1, a0 + j1])
    base = 1 + (rings - 2) * segments
    for j in range(segments):
        tris.append([last, base + (j + 1) % segments, base + j])
    tris = np.asarray(tris, np.int32)
    normals = unit[tris].astype(np.float32) if smooth else None
    ids = None if material is None else np.full(len(tris), material, np.int32)
    return wrt.Mesh(
        name, unit * radius + np.asarray(center, np.float64), tris, np.arange(len(tris)), normals=normals,
        double_sided=False, material_ids=ids,
    )


def top_down_camera(center=(0, 0, 0), height=0.5, distance=5.0) -> wrt.Camera:
    """Orthographic camera above ``center`` looking down -Z at a ``height`` x ``height`` patch of the z = 0 plane."""
    c = np.asarray(center, np.float64)
    return wrt.Camera.orthographic(eye=c + (0, 0, distance), target=c, up=(0, 1, 0), height=height)


def pixel_points(cam_center, height, width_px, height_px, z=0.0) -> np.ndarray:
    """World positions on the plane ``z`` seen by the pixel centres of :func:`top_down_camera`, ``(H, W, 3)``."""
    c = np.asarray(cam_center, np.float64)
    xs = c[0] + ((np.arange(width_px) + 0.5) / width_px - 0.5) * height * width_px / height_px
    ys = c[1] + (0.5 - (np.arange(height_px) + 0.5) / height_px) * height
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx, gy, np.full_like(gx, z)], axis=-1)


def linear_weights(coords, n, wrap=False):
    """``(P, n)`` weights of the ``n`` texels in a linear interpolation between their centres ``k + 1/2`` at
    continuous coordinates ``coords`` ``(P,)`` (0 at the outer edge of texel 0): constant beyond the first and last
    centres, or with ``wrap`` continuing periodically (``np.interp`` of each texel's indicator)."""
    coords = np.asarray(coords, np.float64).reshape(-1)
    centres = np.arange(n) + 0.5
    indicators = np.eye(n)
    if wrap:
        coords = np.mod(coords, n)
        centres = np.concatenate([[-0.5], centres, [n + 0.5]])
        indicators = np.concatenate([indicators[-1:], indicators, indicators[:1]])
    return np.stack([np.interp(coords, centres, indicators[:, k]) for k in range(n)], -1)


def bilinear(image, x, y, wrap_x=False):
    """``(P, C)`` bilinear interpolation of ``image`` ``(H, W, C)`` at texel coordinates ``x, y`` ``(P,)`` from its
    top-left corner: clamped at the edges, columns wrapping around with ``wrap_x``."""
    wx = linear_weights(x, image.shape[1], wrap_x)
    wy = linear_weights(y, image.shape[0])
    return np.einsum("pr,pc,rck->pk", wy, wx, np.asarray(image, np.float64))


def dome_integral(texture, upper_only, n=512):
    """``(3,)`` integral over the upper hemisphere of ``L cos(theta) / pi`` (``upper_only``: the irradiance over pi
    of a plane facing +Y), else the mean of ``L`` over the sphere, of the bilinearly filtered lat-long ``texture``
    (midpoint rule on an ``n x 2n`` grid in ``theta`` from +Y and longitude ``phi``)."""
    height, width = texture.shape[:2]
    span = np.pi / 2 if upper_only else np.pi
    theta = (np.arange(n) + 0.5) / n * span
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    # Direction (sin theta sin phi, cos theta, sin theta cos phi) has longitude phi: texel x = (1/2 - phi / 2pi) W.
    wy = linear_weights(theta / np.pi * height, height)
    wx = linear_weights((0.5 - phi / (2 * np.pi)) * width, width, wrap=True)
    radiance = np.einsum("tr,rck,pc->tpk", wy, texture.astype(np.float64), wx, optimize=True)
    weight = np.sin(theta) * (np.cos(theta) / np.pi if upper_only else 1 / (4 * np.pi)) * (span / n) * (np.pi / n)
    return np.einsum("tpk,t->k", radiance, weight)
