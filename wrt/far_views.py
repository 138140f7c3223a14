"""Cameras too far from what they see for float32: named in warnings.

Rays are traced in float32, which resolves a distance along a ray only to about ``2^-23`` of the ray's reach (the
eye's distance from the origin plus the hit's from the eye). A camera 1e8 from a scene four units across, through a
lens that frames it, resolves depths to 8 units: a card 0.5 in front of a floor was drawn behind it, and a small
light vanished (:func:`warn_scene_too_far`); so, through the eye's own distance from the origin, does a camera
beside a scene 1e7 from the origin, and there the warning names the scene's place, not the camera, as the cause. An
analytic shape's hit is found and shaded in its own space, but from a ray whose float32 origin and ``t`` carry that
error (``wrt.shade.shape_frame`` sums the point relative to the shape, so the shape's own distance from the origin
adds none): where it is a good share of the shape's size its normal is wrong and a single-sided shape's hits are
culled as back faces, so a unit sphere seen from 1e8 vanished (:func:`warn_shapes_too_far`). Either matters only
where what is lost covers a pixel or more, which, from that far, takes a very long lens: a usual camera sees such a
scene as a dot, correctly. Both went without a word before.

A Renderer says each warning once (``shown``), not once per camera upload, which an animated far camera given by
``set_cameras`` makes every frame (its distance in the words changing with it): the scene's once for each camera, and
each shape's once for each camera, in the first warning that finds it lost. A camera is named by its path, or one
made in Python (labelled ``camera``) by its place among several, so that each camera of a batch is warned of: keyed by
the label, only the first of them was. Keyed by the set of shapes lost, a shape was named again whenever another
joined or left the set.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import weakref

import numpy as np

from .camera import APERTURE_UNIT, Camera
from .errors import warn_keyed

FLOAT32_STEP = 2.0**-23  # float32's spacing relative to the magnitude (machine epsilon)
ERROR_SHARE = 0.125  # hit-point error, as a share of the shape's size, past which its normal is visibly wrong
FLAT_KINDS = ("plane", "disk")  # their normal is the same everywhere: the error does not turn it
_SHARED_SHOWN: contextvars.ContextVar[set | None] = contextvars.ContextVar("wrt_far_views_shown", default=None)


@contextlib.contextmanager
def shown_across_renderers(shown: set):
    """Renderers made inside take ``shown`` as the far-view warnings said (:func:`shown_set`), so that each is said
    once over all of them: a loop of :func:`wrt.render` calls makes one per call, and the warnings name the camera's
    distance, so a deduplication by message said them again at every frame of a moving camera.
    (:class:`wrt.animation.FrameRenderer` gives each frame a new set, so that a frame's log row lists every warning
    of that frame, and says each once over the frames itself, by the warnings' keys.)"""
    token = _SHARED_SHOWN.set(shown)
    try:
        yield
    finally:
        _SHARED_SHOWN.reset(token)


def shown_set() -> set:
    """The set of warnings said once (the far-view ones, a camera that sees nothing, and those of each image:
    ``Renderer._warn_once``) that a new Renderer keeps: the one :func:`shown_across_renderers` shares, else a new
    one."""
    shared = _SHARED_SHOWN.get()
    return set() if shared is None else shared


# wrt.render's warnings said, per scene (shown_for_scene): by stage file (its modification time and set: one set per
# file, replaced when the file is edited), or by the id of a scene made in Python (dropped with the scene).
_SCENES_SHOWN: dict = {}


def shown_for_scene(scene) -> set:
    """The warnings said once that the Renderer of a :func:`wrt.render` call of ``scene`` shares with every other
    call's: the set that :func:`shown_across_renderers` shares where one is, else the scene's own for the process. A
    loop calling ``wrt.render`` per frame (a new seed, an edited scene, the stage loaded at each frame's time) made a
    Renderer per call, each saying its warnings again, their counts new at every frame. A stage is keyed by its file
    and the file's modification time (a file edited since is warned of again); a scene made in Python by itself."""
    shared = _SHARED_SHOWN.get()
    if shared is not None:
        return shared
    from .render_log import mtime_ns

    if scene.source:
        # Only the file's current version: keyed by (file, time) too, each edit left the set of the one before, which
        # no later call could reach, and a file written anew at every frame grew the dict by a set a frame.
        path, mtime = os.path.abspath(scene.source), mtime_ns(scene.source)
        kept = _SCENES_SHOWN.get(path)
        if kept is None or kept[0] != mtime:
            kept = _SCENES_SHOWN[path] = (mtime, set())
        return kept[1]
    key = ("scene", id(scene))
    if key not in _SCENES_SHOWN:
        _SCENES_SHOWN[key] = set()
        weakref.finalize(scene, _SCENES_SHOWN.pop, key, None)  # its id may be another scene's once it is gone
    return _SCENES_SHOWN[key]


def _pixel_footprints(cam: Camera, width: int, height: int, centres: np.ndarray, sizes: np.ndarray) -> tuple:
    """``(footprint, ahead)`` of objects of world ``sizes`` (radii) at world ``centres`` ``(N, 3)``: the world size of
    one pixel there (film units per pixel, in direction units per unit of camera depth for a perspective camera or in
    scene units for an orthographic one, times the world length of the camera's y axis), and whether the object is
    not wholly behind a perspective eye."""
    film_w, film_h = cam.film_size(width, height)
    per_pixel = min(film_w / width, film_h / height) * float(np.linalg.norm(cam.to_world[:3, 1]))
    if cam.projection != "perspective":
        return np.full(len(centres), per_pixel * APERTURE_UNIT), np.ones(len(centres), bool)
    depth = -((centres - cam.to_world[:3, 3]) @ np.linalg.inv(cam.to_world)[2, :3])  # camera-space depth
    ahead = depth + sizes * float(np.linalg.norm(cam.to_world[:3, 2])) > 0.0
    return per_pixel / cam.focal_length * np.maximum(depth, 0.0), ahead


def hit_error(cam: Camera, points: np.ndarray) -> np.ndarray:
    """``(N,)`` about how far from the true hit float32 puts a hit at world ``points`` seen by ``cam``."""
    eye = cam.to_world[:3, 3]
    return FLOAT32_STEP * (np.linalg.norm(eye) + np.linalg.norm(points - eye, axis=1))


def warn_scene_too_far(scene, cam: Camera, width: int, height: int, shown: set, name: str) -> None:
    """Warns naming ``cam`` (as ``name``) where its rays resolve distances at the scene to worse than
    :data:`ERROR_SHARE` of the scene's size while the scene covers a pixel or more (see the module docstring); not
    where ``shown`` holds the warning of a camera of that name already (each one given is added to it). The warning
    says what is far: the camera from the scene, or (the camera nearer it than the origin is) the scene from the
    world origin."""
    key = ("scene too far", name)
    if key in shown:
        return
    lower, upper = (np.asarray(b, np.float64) for b in scene.bounds())
    with np.errstate(all="ignore"):
        diagonal = float(np.linalg.norm(upper - lower))
        centre = (0.5 * (lower + upper))[None]
        error = float(hit_error(cam, centre)[0] + FLOAT32_STEP * 0.5 * diagonal)
        footprint, ahead = _pixel_footprints(cam, width, height, centre, np.array([0.5 * diagonal]))
        lost = bool(ahead[0]) and error > ERROR_SHARE * diagonal and diagonal > footprint[0]
    if lost:
        shown.add(key)
        distance = float(np.linalg.norm(centre[0] - cam.to_world[:3, 3]))
        offset = float(np.linalg.norm(centre[0]))  # the scene's distance from the world origin
        source = scene.source or "scene"
        lost_words = (f"float32 resolves distances along its rays only to about {error:.2g} units: surfaces nearer "
                      "each other than that are drawn in the wrong order, and small lights and shapes vanish")
        # The error grows with the eye's distance from the origin plus the hit's from the eye: with the camera beside
        # a scene far from the origin the first term is the scene's place, which the warning blamed on the camera.
        if distance >= offset:
            message = (f"{source}: {name} is so far from the scene ({distance:.3g} units; it is {diagonal:.3g} "
                       f"across) that {lost_words} (move the camera nearer, with a wider lens)")
        else:
            message = (f"{source}: the scene lies so far from the world origin ({offset:.3g} units; it is "
                       f"{diagonal:.3g} across, {name} {distance:.3g} units from it) that, seen by {name}, "
                       f"{lost_words} (move the scene and camera nearer the origin, e.g. by a transform on the "
                       "stage's root)")
        warn_keyed(message, key)


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


def warn_shapes_too_far(scene, cam: Camera, width: int, height: int, shown: set, name: str) -> None:
    """Warns naming ``cam`` (as ``name``) and the curved analytic shapes (not planes or disks) that it
    sees over a pixel or more and whose float32 hit points err by more than :data:`ERROR_SHARE` of their size (see
    the module docstring); shapes that ``shown`` holds the warning of for a camera of that name already are left out
    (each one named is added to it)."""
    if not scene.shapes and not any(getattr(p, "shapes", None) for p in scene.prototypes):
        return
    geometry = scene._geometry_shapes()
    with np.errstate(all="ignore"):
        centres, size, ids = shape_centres_and_sizes(scene)
        curved = np.array([s.kind not in FLAT_KINDS for s in geometry], bool)[ids]
        error = hit_error(cam, centres)
        footprint, ahead = _pixel_footprints(cam, width, height, centres, size)
        lost = curved & ahead & (error > ERROR_SHARE * size) & (2.0 * size > footprint)
    if lost.any():
        # Only the lost entries' shapes are looked up, each once: a loop over every entry (200k instances) ran at
        # every camera upload of every camera.
        lost_ids = ids[lost]
        said = [j for j in np.unique(lost_ids) if ("shape too far", name, geometry[j].path) in shown]
        lost[lost] = ~np.isin(lost_ids, said)
    if lost.any():
        unique, first = np.unique(ids[lost], return_index=True)
        paths = list(dict.fromkeys(geometry[j].path for j in unique[np.argsort(first)]))  # in the order found
        keys = tuple(("shape too far", name, path) for path in paths)
        shown.update(keys)
        worst = float(np.max(error[lost]))
        scene._warn_prims(f"{name} sees analytic shapes from so far for their size that float32 places its "
                          f"hit points on them only to within about {worst:.2g} units: their normals are wrong and "
                          "single-sided ones vanish (move the camera nearer, or make them meshes)", paths, key=keys)
