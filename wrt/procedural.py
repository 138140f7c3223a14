"""Procedural meshes for benchmarks and tests: a displaced, finely subdivided sphere of any triangle count."""

from __future__ import annotations

import numpy as np

from .scene import Scene


def displaced_sphere(triangles: int, *, radius: float = 1.0, amplitude: float = 0.15, seed: int = 0):
    """A closed UV sphere of about ``triangles`` triangles whose radius is displaced by smooth random waves.

    Rings and segments are chosen so that ``2 * rings * segments`` (the triangle count without the pole caps'
    degenerate halves) is close to ``triangles``; poles are single vertices, so the mesh is closed.

    Returns:
        ``points`` ``(V, 3)`` float32 and ``indices`` ``(T, 3)`` int32.
    """
    if triangles < 8:
        raise ValueError(f"a displaced sphere needs at least 8 triangles, got {triangles}")
    rings = max(int(round(np.sqrt(triangles / 4.0))), 2)
    segments = max(int(round(triangles / (2.0 * rings))), 3)
    rng = np.random.default_rng(seed)
    theta = np.pi * np.arange(1, rings) / rings  # inner rings only; poles added separately
    phi = 2.0 * np.pi * np.arange(segments) / segments
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    dirs = np.stack([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)], axis=-1).reshape(-1, 3)
    dirs = np.concatenate([[[0.0, 1.0, 0.0]], dirs, [[0.0, -1.0, 0.0]]])
    # Smooth displacement: a sum of a few random plane waves over the unit sphere.
    waves = rng.normal(size=(6, 3)) * rng.uniform(2.0, 9.0, size=(6, 1))
    phases = rng.uniform(0, 2 * np.pi, 6)
    bump = np.sin(dirs @ waves.T + phases).mean(axis=1)
    points = (dirs * (radius * (1.0 + amplitude * bump))[:, None]).astype(np.float32)

    ring = lambda r, s: 1 + r * segments + (s % segments)  # noqa: E731  vertex id of inner ring r, segment s
    s = np.arange(segments)
    top = np.stack([np.zeros(segments, int), ring(0, s + 1), ring(0, s)], axis=1)
    bottom_id = len(points) - 1
    bottom = np.stack([np.full(segments, bottom_id), ring(rings - 2, s), ring(rings - 2, s + 1)], axis=1)
    r, s2 = np.meshgrid(np.arange(rings - 2), s, indexing="ij")
    r, s2 = r.ravel(), s2.ravel()
    a, b, c, d = ring(r, s2), ring(r, s2 + 1), ring(r + 1, s2 + 1), ring(r + 1, s2)
    quads = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    indices = np.concatenate([top, quads, bottom]).astype(np.int32)
    return points, indices


def displaced_sphere_scene(triangles: int, seed: int = 0) -> Scene:
    """:func:`displaced_sphere` wrapped in a :class:`Scene`."""
    points, indices = displaced_sphere(triangles, seed=seed)
    return Scene.from_triangles(points, indices, name=f"/displaced_sphere_{len(indices)}")
