"""Analytic shapes a camera sees from too far for float32 hit points: named in a warning.

The renderer finds a shape's hit in the shape's own space, precisely, but shades it at the world point ``o + t d``,
which float32 places only to within about ``2^-23`` of the ray's reach (the eye's distance from the origin plus the
hit's from the eye). The shape's normal is taken at that point: where the error is a good share of the shape's size
the normal is wrong, and a single-sided shape's hits are culled as back faces. A unit sphere seen from 1e8 (an
error of 8 units) through a lens that frames it vanished without a word. Such a shape matters only where it covers
a pixel or more, which, from that far, takes a very long lens: a usual camera sees it as a dot, correctly.
"""

from __future__ import annotations

import numpy as np

from .camera import APERTURE_UNIT, Camera

FLOAT32_STEP = 2.0**-23  # float32's spacing relative to the magnitude (machine epsilon)
ERROR_SHARE = 0.125  # hit-point error, as a share of the shape's size, past which its normal is visibly wrong
FLAT_KINDS = ("plane", "disk")  # their normal is the same everywhere: the error does not turn it


def _smallest_scale(linear: np.ndarray) -> np.ndarray:
    """``(N,)`` a lower bound of the smallest singular value of each ``(N, 3, 3)`` matrix, ``|det| / (largest column
    length)^2``, exact for a uniform scale: a squashed shape counts as small as it is along its thin axis."""
    widest = np.linalg.norm(linear, axis=1).max(axis=1)
    return np.abs(np.linalg.det(linear)) / (widest * widest)


def shape_centres_and_sizes(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World centres ``(S, 3)``, sizes ``(S,)`` (the smallest world radius of each canonical unit shape, a lower
    bound, :func:`_smallest_scale`) and indices ``(S,)`` into ``scene._geometry_shapes()`` of every analytic shape
    as placed: the non-instanced ones, then each prototype's for each of its instances (an instance's size from its
    cached inverse: ``1 / |A|_F``, a lower bound too, so no ``(S, 4, 4)`` product is made for a million instances)."""
    geometry = scene._geometry_shapes()
    if not geometry:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64)
    to_world = np.array([np.asarray(shape.to_world, np.float64) for shape in geometry]).reshape(-1, 4, 4)
    own_size = _smallest_scale(to_world[:, :3, :3])
    n = len(scene.shapes)
    centres, sizes, ids = [to_world[:n, :3, 3]], [own_size[:n]], [np.arange(n)]
    instances = scene.instances
    if len(instances) and len(geometry) > n:
        inverses = scene.instance_inverses()[0]
        instance_size = 1.0 / np.linalg.norm(inverses[:, :, :3], axis=(1, 2))
        rows = instances.rows_of_prototypes(len(scene.prototypes))
        first = n
        for p, prototype in enumerate(scene.prototypes):
            for k in range(first, first + len(getattr(prototype, "shapes", []))):
                m = instances.to_world[rows[p]]
                centres.append(np.einsum("nij,j->ni", m[:, :3, :3], to_world[k, :3, 3]) + m[:, :3, 3])
                sizes.append(instance_size[rows[p]] * own_size[k])
                ids.append(np.full(len(rows[p]), k))
            first += len(getattr(prototype, "shapes", []))
    return np.concatenate(centres), np.concatenate(sizes), np.concatenate(ids).astype(np.int64)


def warn_shapes_too_far(scene, cam: Camera, width: int, height: int) -> None:
    """Warns naming ``cam`` and the curved analytic shapes (not planes or disks) that it sees over a pixel or more
    and whose float32 hit points err by more than :data:`ERROR_SHARE` of their size (see the module docstring)."""
    if not scene.shapes and not any(getattr(p, "shapes", None) for p in scene.prototypes):
        return
    geometry = scene._geometry_shapes()
    with np.errstate(all="ignore"):
        centres, size, ids = shape_centres_and_sizes(scene)
        curved = np.array([s.kind not in FLAT_KINDS for s in geometry], bool)[ids]
        eye = cam.to_world[:3, 3]
        error = FLOAT32_STEP * (np.linalg.norm(eye) + np.linalg.norm(centres - eye, axis=1))
        # Footprint of a pixel at each shape: film units per pixel, in direction units per unit of camera depth
        # (perspective) or in scene units (orthographic), times the world length of the camera's y axis.
        film_w, film_h = cam.film_size(width, height)
        per_pixel = min(film_w / width, film_h / height) * float(np.linalg.norm(cam.to_world[:3, 1]))
        if cam.projection == "perspective":
            depth = -((centres - eye) @ np.linalg.inv(cam.to_world)[2, :3])  # camera-space depth
            footprint = per_pixel / cam.focal_length * np.maximum(depth, 0.0)
            ahead = depth + size * float(np.linalg.norm(cam.to_world[:3, 2])) > 0.0  # not wholly behind the eye
        else:
            footprint = np.full(len(centres), per_pixel * APERTURE_UNIT)
            ahead = np.ones(len(centres), bool)
        lost = curved & ahead & (error > ERROR_SHARE * size) & (2.0 * size > footprint)
    if lost.any():
        paths = list(dict.fromkeys(geometry[j].path for j in ids[lost]))
        worst = float(np.max(error[lost]))
        scene._warn_prims(f"{cam.label()} sees analytic shapes from so far for their size that float32 places its "
                          f"hit points on them only to within about {worst:.2g} units: their normals are wrong and "
                          "single-sided ones vanish (move the camera nearer, or make them meshes)", paths)
