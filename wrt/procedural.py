"""Procedural scenes for benchmarks and tests: a displaced, finely subdivided sphere of any triangle count, a
sensor-style scene of primitives plus meshes, and rings of cameras."""

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


def sensor_scene(boxes: int = 6, spheres: int = 3, blob_triangles: int = 0) -> Scene:
    """Primitives plus meshes, as robot-sensor scenes are: a ground quad, ``boxes`` instances of one box mesh in a
    row, ``spheres`` analytic spheres, optionally a displaced-sphere mesh of ``blob_triangles``, and a sun."""
    from .instancing import Instances, Prototype
    from .primitives import Shape
    from .scene import DistantLight

    quad = np.array([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]], np.float32)
    scene = Scene.from_triangles(quad, np.array([[0, 2, 1], [0, 3, 2]], np.int32))
    if blob_triangles:
        points, indices = displaced_sphere(blob_triangles)
        blob = Scene.from_triangles(points * 0.5 + np.float32([0.0, 1.2, -1.5]), indices)
        scene.meshes += blob.meshes
    corners = np.array([[x, y, z] for z in (-0.3, 0.3) for y in (0, 0.6) for x in (-0.3, 0.3)], np.float32)
    faces = [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4]]
    faces += [[2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]]
    box = Scene.from_triangles(corners, np.array(faces, np.int32))
    to_world = np.repeat(np.eye(4)[None], boxes, axis=0)
    to_world[:, 0, 3] = np.linspace(-2, 2, boxes)
    to_world[:, 2, 3] = np.linspace(1, -1, boxes)
    scene.prototypes = [Prototype(path="/box", meshes=box.meshes)]
    scene.instances = Instances.from_transforms(np.zeros(boxes, np.int32), to_world)
    for k in range(spheres):
        m = np.eye(4)
        m[:3, :3] *= 0.4
        m[:3, 3] = (-1.5 + 3.0 * k / max(spheres - 1, 1), 0.4, 1.8)
        scene.shapes.append(Shape(path=f"/ball{k}", kind="sphere", to_world=m))
    sun = np.array([-0.3, -1.0, -0.2])
    scene.lights.append(DistantLight(direction=sun / np.linalg.norm(sun), color=np.full(3, 3.0, np.float32)))
    return scene


def ring_of_cameras(n: int, radius: float = 5.0) -> list:
    """``n`` cameras around the origin, each with its own pose and intrinsics: field of view, film offset, every
    seventh orthographic, every fifth with a thin lens."""
    from .camera import Camera

    cams = []
    for k in range(n):
        a = 2 * np.pi * k / n
        eye = (radius * np.cos(a), 1.5 + (k % 3) * 0.5, radius * np.sin(a))
        if k % 7 == 3:
            cams.append(Camera.orthographic(eye, (0, 0.3, 0), height=4.0 + k % 2))
            continue
        cam = Camera.look_at(eye, (0, 0.3, 0), fov_y_deg=25 + 3 * (k % 10))
        cam.horizontal_aperture_offset = 0.5 * (k % 4)
        if k % 5 == 1:
            cam.f_stop, cam.focus_distance = 0.8, radius
        cams.append(cam)
    return cams
