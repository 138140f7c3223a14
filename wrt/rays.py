"""Ray sets for testing and benchmarking: camera rays and random rays through a scene's bounds.

All functions return ``(origins, directions)`` as ``(N, 3)`` float32 numpy arrays and are deterministic in
their ``seed``.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .camera import Camera, generate_rays_kernel
from .render import resolve_camera
from .scene import Scene


def camera_rays(scene: Scene, camera=None, width: int = 320, height: int = 240) -> tuple[np.ndarray, np.ndarray]:
    """One ray through the centre of each pixel of ``camera`` (see :func:`wrt.render.resolve_camera`), row-major
    from the top-left, exactly as the renderer casts its first sample."""
    cam: Camera = resolve_camera(scene, camera)
    n = width * height
    out = [wp.empty(n, dtype=wp.vec3, device="cpu") for _ in range(2)]
    out += [wp.empty(n, dtype=float, device="cpu") for _ in range(2)]
    wp.launch(generate_rays_kernel, n, inputs=[cam.to_struct(width, height), width, height, 0, 0], outputs=out, device="cpu")
    return out[0].numpy(), out[1].numpy()


def random_rays(scene: Scene, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` incoherent rays: half start outside the scene box and aim at random points inside it (most hit),
    half start at random points inside the box with uniformly random unit directions."""
    rng = np.random.default_rng(seed)
    lower, upper = (np.asarray(b, np.float64) for b in scene.bounds())
    extent = np.maximum(upper - lower, 1e-6 * max(float(np.abs(upper - lower).max()), 1e-30))
    n_aimed = n // 2
    origins_out = rng.uniform(lower - extent, upper + extent, (n_aimed, 3))
    targets = rng.uniform(lower, upper, (n_aimed, 3))
    origins_in = rng.uniform(lower, upper, (n - n_aimed, 3))
    directions_in = rng.normal(size=(n - n_aimed, 3))
    directions_in /= np.linalg.norm(directions_in, axis=1, keepdims=True)
    origins = np.concatenate([origins_out, origins_in]).astype(np.float32)
    directions = np.concatenate([targets - origins_out, directions_in]).astype(np.float32)
    return origins, directions
