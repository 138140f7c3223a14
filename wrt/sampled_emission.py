"""The emission each triangle (and analytic shape) of a textured emitter shows, read at points of the triangle (at
the shape's one ``st``) by the render's own lookup (:func:`wrt.materials.eval_emission`), for the light table's choice
of which triangles and shapes to sample and how often (:mod:`wrt.light_table`, :mod:`wrt.glowing_spheres`).

A material's emission estimate (:func:`wrt.materials.emission_estimate`) is the mean of its texture's texels, which
misses what the lookup returns besides them: a UDIM texture's fallback on a tile without a file (or outside the
tiles), a MaterialX image's ``default`` outside [0, 1] under the ``constant`` address mode, any texture's fallback at
non-finite texture coordinates. A texture of black texels whose fallback glows was estimated as no light: its
triangles were never sampled (``whitted`` left what they light black, and a stage lit by them alone got the default
lights), and ``path`` found their light only through the rays that happened to hit them. Each such triangle takes
the larger of its material's estimate and the mean emission at :data:`BARYCENTRIC_POINTS`, so that the estimate and
the render cannot disagree on where the glow is, and no triangle is estimated below its material's mean.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .materials import DeviceMaterials, eval_emission

# The same rounding on every device, as the light table it feeds (see wrt/shade.py); no adjoint code to compile.
wp.set_module_options({"fuse_fp": False, "enable_backward": False})

# Points read on each triangle (barycentric weights of corners 0, 1, 2): the centroid and one towards each corner.
BARYCENTRIC_POINTS = np.array([[1, 1, 1], [4, 1, 1], [1, 4, 1], [1, 1, 4]], np.float64) / np.array([[3], [6], [6], [6]])


@wp.kernel
def sample_emission_kernel(mats: DeviceMaterials, uvs: wp.array2d[wp.vec2], ids: wp.array[wp.int32],
                           materials: wp.array[wp.int32], weights: wp.array[wp.vec3],
                           # outputs
                           emission: wp.array[wp.vec3]):
    """``emission[i]``: the mean emission of material ``materials[i]`` on triangle ``ids[i]`` at the barycentric
    points ``weights``, each component clamped to 0 first (a component below 0 adds no light)."""
    i = wp.tid()
    t = ids[i]
    total = wp.vec3(0.0)
    for j in range(weights.shape[0]):  # (a bound read at run time: one lookup compiled, not one per point)
        w = weights[j]
        e = eval_emission(mats, materials[i], w[0] * uvs[t, 0] + w[1] * uvs[t, 1] + w[2] * uvs[t, 2])
        total += wp.vec3(wp.max(e[0], 0.0), wp.max(e[1], 0.0), wp.max(e[2], 0.0))
    emission[i] = total / float(weights.shape[0])


def sampled_emission(mats: DeviceMaterials, uvs: wp.array2d[wp.vec2], tri_materials: np.ndarray,
                     estimates: np.ndarray, sampled: np.ndarray, device) -> np.ndarray | None:
    """``(T, 3)`` float64 emission estimate per triangle (``T = len(tri_materials)``, the geometry's triangles then
    one row per analytic shape): its material's ``estimates`` row, or for a material marked in ``sampled`` the larger
    of that and the mean emission at :data:`BARYCENTRIC_POINTS` (:func:`sample_emission_kernel`; a shape's three
    corners are its one ``st``, where the render reads its glow); None where no row is of a ``sampled`` material.

    Args:
        mats: the scene's device materials (:func:`wrt.materials.upload_materials`).
        uvs: ``(T, 3)`` texture coordinates per corner on ``device`` (:meth:`wrt.Scene.corner_uvs`).
        tri_materials: ``(T,)`` int device material of each row.
        estimates: ``(M, 3)`` emission estimate per device material (:func:`wrt.materials.emission_estimates`).
        sampled: ``(M,)`` bool, the materials whose emission is read on their triangles (those with an emission
            texture).
        device: the Warp device of ``mats`` and ``uvs``.
    """
    sampled = np.asarray(sampled, bool)
    if not sampled.any():  # (no per-triangle gather: most scenes have no textured emitter)
        return None
    tri_materials = np.asarray(tri_materials)
    ids = np.flatnonzero(sampled[tri_materials]).astype(np.int32)
    if len(ids) == 0:
        return None
    read = wp.empty(len(ids), dtype=wp.vec3, device=device)
    wp.launch(sample_emission_kernel, dim=len(ids), device=device,
              inputs=[mats, uvs, wp.array(ids, dtype=wp.int32, device=device),
                      wp.array(tri_materials[ids].astype(np.int32), dtype=wp.int32, device=device),
                      wp.array(BARYCENTRIC_POINTS.astype(np.float32), dtype=wp.vec3, device=device)],
              outputs=[read])
    # A sum past float32's range (texels near 65504 times a huge scale) as the largest float.
    mean = np.nan_to_num(read.numpy(), nan=0.0, posinf=np.finfo(np.float32).max)
    emission = np.asarray(estimates, np.float64).reshape(-1, 3)[tri_materials]
    emission[ids] = np.maximum(emission[ids], mean)
    return emission
