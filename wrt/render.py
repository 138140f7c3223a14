"""Rendering: camera paths -> trace -> shade, bounce by bounce, into an :class:`Image`, as a reusable
:class:`Renderer` and ``render()``.

The loop is a wavefront (generate -> intersect -> shade/extend -> occluded -> accumulate, per bounce): every kernel
works on the arrays of all live paths, and all ray queries go through the :class:`wrt.trace.Accelerator`, so
``accel="wrt"`` and ``accel="warp"`` serve every integrator (see :mod:`wrt.integrators`).

Samples are deterministic in ``(seed, pixel, sample index)`` and are summed in sample order, so an image does not
depend on how its samples are split into launches (``batch``). ``Image.rgb`` is their mean: linear radiance.
"""

from __future__ import annotations

import contextlib
import functools
import math
import threading
import warnings
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
import warp as wp

from . import emitter_resampling
from .camera import APERTURE_UNIT, CAMERA_FIELDS, FLOAT32_MAX, Camera, DeviceCamera, frame_scene
from .errors import SceneError, did_you_mean, flag, user_stacklevel, warn_keyed
from .far_views import (
    shown_across_renderers,
    shown_for_scene,
    shown_set,
    warn_scene_too_far,
    warn_shapes_too_far,
)
from .hidden_hits import CullScratch, intersect_visible, occluded_through_holes
from .image import Image, depth_grey
from .integrators import INTEGRATORS, LIGHT_SAMPLING_INTEGRATORS
from .integrators.ao import ao_value_kernel, shade_ao_kernel
from .integrators.path import path_kernels
from .integrators.whitted import (
    ShadowRays,
    lights_per_batch,
    whitted_kernels,
)
from .light_table import build_lights, seen_by_camera, set_headlight_directions
from .lights import check_folded_inputs, check_light_types, default_lights
from .materials import (
    emission_estimates,
    fallback_glows,
    tile_emission_estimates,
    upload_materials,
    wholly_cut_out,
)
from .options import AOV_NAMES as AOV_NAMES  # re-exported: see wrt.options
from .options import DATA_INTEGRATORS, DEFAULT_MAX_DEPTH, MAX_DEPTH, MAX_SPP, QUICK_LOOKS
from .radiance_scale import glow_bounds, scaled_materials
from .render_settings import DEFAULT_HEIGHT, DEFAULT_WIDTH, FULL_WINDOW
from .resources import check_memory
from .sampled_emission import block_maps, sampled_emission
from .scene import IdRows, Scene, dataclass_field_names, dataclass_parts, has_area, parts_changed
from .shade import (
    FIRST_AT_CENTRE,
    FIRST_ON_LENS,
    FIRST_SPREAD,
    MAX_CULL_PASSES,
    MAX_SHADOW_HOLE_PASSES,
    DeviceSurfaces,
    accumulate_samples_kernel,
    add_covered_kernel,
    count_alive_kernel,
    count_covered_kernel,
    coverage_kernel,
    mean_image_kernel,
    primary_aovs_kernel,
    start_paths_kernel,
)
from .textures import scene_images
from .trace import HitBuffer, check_scene, get_accelerator, resolve_device, resolve_threads, run_in_chunks
from .wording import counted

MAX_PIXELS = 1 << 26  # 67 Mpixel: larger requests are refused before allocating
MAX_PATHS_PER_LAUNCH = 1 << 20  # default batch: as many samples per launch as fit in this many paths
MAX_LAUNCH_PATHS = (1 << 31) - 1  # Warp's arrays and wp.tid() are 32-bit: no launch can index more paths
RR_DEPTH = 3  # Russian roulette starts after this many bounces
MAX_SEED = 0x7FFFFFFF  # seeds are 31-bit (wp.rand_init takes a signed 32-bit seed)
# Most back-face cull passes of camera rays in a frame of launch_frame in a scene without cut-outs (outside a graph
# capture all of them run: no host reads); with cut-outs up to MAX_CULL_PASSES, to pass as many holes as render.
CAPTURE_CULL_PASSES = 2


def next_number(number: int) -> int:
    """``number + 1`` within int32's positive range, 0 after 2^31 - 1: the renderer's upload and frame-buffer numbers
    are compared with their copies in device int32s, which wrapped negative past 2^31 - 1 while the Python count did
    not, and every frame_image of a simulation that had called set_cameras at each of 2^31 steps raised from then on."""
    return (number + 1) % (1 << 31)


def check_pixels(width: int, height: int, n_views: int = 1) -> None:
    """Raises ``ValueError`` when ``n_views`` images of ``width x height`` exceed ``MAX_PIXELS``."""
    if width * height * n_views > MAX_PIXELS:
        # "1 x 200000x200000 is 40000000000 pixels" read as a product of three sizes; a count of images only where
        # there are several, and digits in groups.
        images = f"{width}x{height} is" if n_views == 1 else f"{n_views:,} images of {width}x{height} are"
        raise ValueError(f"{images} {n_views * width * height:,} pixels; at most {MAX_PIXELS:,} are supported")


def check_view_pixels(width: int, height: int, n_views: int, given: list, settings_name: str | None,
                      windowed: bool = False) -> None:
    """:func:`check_pixels`, its error naming where the size came from: ``given``, the sides given as their caller
    spells them (``--width 8``, ``width=8``), and ``settings_name``, the render settings that gave a side where there
    are some (their resolution, or their aspect where one side was given), and their data window where it made the
    image another size (``windowed``). A size from a stage's RenderSettings was refused as "2147483647x2 is ...
    pixels", naming neither, and one that a dataWindowNDC overscan grew was blamed on the resolution."""
    try:
        check_pixels(width, height, n_views)
    except ValueError as e:
        parts = [" ".join(given)] if given else []  # "--width 8 --height 9", as typed
        causes = ["aspect" if given else "resolution"] if len(given) < 2 else []
        if windowed:
            causes.append("dataWindowNDC")
        if settings_name is not None and causes:
            parts.append(f"{' and '.join(causes)} of {settings_name}")
        raise ValueError(f"{', '.join(parts)}: {e}" if parts else str(e)) from None


def check_asked_pixels(scene: Scene, width: int, height: int, n_views: int, asked: tuple) -> None:
    """:func:`check_pixels` of ``n_views`` images of ``width x height`` that :func:`resolve_view` made of ``asked``,
    the ``(width, height)`` given (each may be None), its error naming ``scene.render_settings`` where they gave a
    side or their data window changed the size (as the CLI names them: :func:`check_view_pixels`)."""
    settings = scene.render_settings
    given = [f"{name}={side}" for name, side in zip(("width", "height"), asked) if side is not None]
    windowed = settings is not None and (width, height) != settings.image_size(*asked)
    if settings is None or (len(given) == 2 and not windowed):  # the size is the caller's own
        check_pixels(width, height, n_views)
    else:
        check_view_pixels(width, height, n_views, given, f"scene.render_settings {settings.product or settings.path}",
                          windowed)


def warn_unused_integrator_options(integrator: str, max_depth, ao_radius) -> None:
    """Warns of a ``max_depth`` or ``ao_radius`` given to an integrator that does not read it, as ``wrt render`` warns
    of ``--max-depth`` and ``--ao-radius``: ``wrt.render(scene, ao_radius=0.5)`` (whitted) drew the image without
    it, without a word."""
    if ao_radius is not None and integrator != "ao":
        warnings.warn(f"ao_radius applies to integrator 'ao' only; {integrator!r} does not use it", stacklevel=3)
    if max_depth is not None and integrator not in DEFAULT_MAX_DEPTH:
        users = " and ".join(repr(name) for name in DEFAULT_MAX_DEPTH)
        warnings.warn(f"max_depth applies to integrator {users} only; {integrator!r} does not use it", stacklevel=3)


def samples_per_launch(n_pixels: int, spp: int, batch: int | None = None) -> int:
    """Samples per pixel of each launch of a render of ``spp`` samples: ``batch``, by default as many as fit in
    :data:`MAX_PATHS_PER_LAUNCH` paths (at least one), never more than ``spp``."""
    if batch is None:
        batch = max(1, min(spp, MAX_PATHS_PER_LAUNCH // n_pixels))
    return min(int(batch), spp)


def render_bytes(n_pixels: int, paths: int) -> int:
    """Device bytes a render allocates for ``paths`` paths per launch and ``n_pixels`` pixels (summed radiance, its
    mean, the AOVs, the count of covered samples)."""
    aovs = sum(map(wp.types.type_size_in_bytes, _AovBuffers.SPEC.values())) + 3 * 4  # + the coverage counts
    pixel = 2 * wp.types.type_size_in_bytes(wp.vec3) + aovs
    return paths * _Wavefront.bytes_per_path() + n_pixels * pixel


def check_sides(width, height) -> None:
    """Raises ``ValueError`` unless ``width`` and ``height`` are each ``None`` (the render settings' or wrt's
    default) or a positive integer."""
    for name, value in (("width", width), ("height", height)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0):
            raise ValueError(f"{name} must be a positive integer, got {value!r}")


def check_seed(seed) -> int:
    """``seed`` as an int; the generator takes 31-bit seeds, and a float was truncated (0.5 rendered as 0) and
    larger or negative seeds wrapped onto others (2^31 rendered as 0) without a word.

    Raises:
        ValueError: ``seed`` is not an integer from 0 to :data:`MAX_SEED`.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed must be an integer from 0 to {MAX_SEED}, got {seed!r}")
    return int(seed)


def resolve_camera(scene: Scene, camera) -> Camera:
    """``camera`` as a :class:`Camera`: itself, the scene camera at that prim path, the stage's first camera,
    or (for ``None`` on a stage without cameras) one that frames the whole scene."""
    if isinstance(camera, Camera):
        return camera
    if camera is None:
        if scene.cameras:
            return next(iter(scene.cameras.values()))
        lower, upper = scene.bounds()
        return frame_scene(lower, upper, scene.up_axis)
    if type(camera).__name__ == "Path" and type(camera).__module__ == "pxr.Sdf":  # GetPath(): was 'not Path'
        camera = str(camera)
    if isinstance(camera, str):
        if camera in scene.cameras:
            return scene.cameras[camera]
        if camera in scene.skipped_cameras:  # the loader's reason, which a render from another camera only warned of
            raise SceneError(scene.skipped_cameras[camera], path=scene.source, prim=camera)
        there = None
        if scene.source is not None:  # say what is there: '/Box' is a Cube, not a camera
            from .usd_cameras import what_is_at

            there = what_is_at(scene.source, camera, getattr(scene, "_variants", None))
        there = there or f"no camera at {camera!r}{did_you_mean(camera, scene.cameras)}"
        error = SceneError(f"{there}; cameras in the scene: {few_paths(scene.cameras)}", path=scene.source)
        error.prim = camera  # set after: the message names it once, where it reads best
        raise error
    raise TypeError(f"camera must be a wrt.Camera, a prim path string or None, not {type(camera).__name__}")


def camera_name(cam, k: int, count: int) -> str:
    """``cam``'s name in warnings about it, ``cameras[k]`` of ``count``: a camera made in Python is named by its place
    among several as well (its label, "camera" for all of them, named none of them in particular); one alone, or a
    stage camera, by its label."""
    return cam.label() if cam.path or count == 1 else f"{cam.label()} (cameras[{k}])"


def warn_clipped_away(scene: Scene, cameras: list, shown: set | None = None) -> None:
    """Warns of each camera whose clipping range holds no point of the scene's box (a range of (1e30, 1e31), or a
    far plane nearer than the scene): its image is background only, which was drawn without a word. A scene partly
    inside the range is never warned of: the box's corners bound the depth of every point. A camera (by name) and
    clipping range already in ``shown`` is left out, and each one warned of is added to it: keyed by the message,
    which names the scene's extent along the view, a camera moved each step of a long loop warned at every step and
    grew ``shown`` without bound."""
    shown = set() if shown is None else shown
    lower, upper = scene.bounds()
    for k, cam in enumerate(cameras):
        near, far = cam.clipping_range
        name = camera_name(cam, k, len(cameras))
        key = ("clipped away", name, float(near), float(far))
        if key in shown:
            continue
        nearest, farthest = cam.depth_extent(lower, upper)
        if farthest < near or nearest > far:
            shown.add(key)
            warn_keyed(f"{scene.source or 'scene'}: {name} sees nothing: its clipping range ({near:g}, {far:g}) "
                       f"holds no part of the scene, which lies from {nearest:g} to {farthest:g} along its view; the "
                       "image is background only", key)


def few_paths(paths, shown: int = 6) -> str:
    """The first ``shown`` of ``paths`` and how many more (a stage may hold thousands of cameras), or ``none``."""
    paths = list(paths)
    more = f" and {len(paths) - shown} more" if len(paths) > shown else ""
    return ", ".join(paths[:shown]) + more or "none"


def camera_source(scene: Scene, camera) -> Camera | None:
    """The :class:`Camera` a view of ``camera`` (as :func:`resolve_view` takes it) is made from, as it is now: itself,
    the scene's camera at its path (for ``None`` the render settings' camera, else the first), or None where wrt
    makes the camera (a stage without cameras) or the path names no camera now."""
    if isinstance(camera, Camera):
        return camera
    if camera is None:
        settings = scene.render_settings
        camera = settings.camera if settings is not None and settings.camera is not None else None
        if camera is None:
            return next(iter(scene.cameras.values()), None)
    return scene.cameras.get(str(camera))


def default_image_size(camera: Camera | None, width: int | None, height: int | None) -> tuple[int, int]:
    """``(width, height)`` of a render without render settings: the given ones; where one alone is given, the other
    keeps ``camera``'s aspect (:meth:`Camera.image_aspect`: its apertures', else, and for ``None``, the camera wrt
    frames a scene with, the 4:3 of ``DEFAULT_WIDTH x DEFAULT_HEIGHT``), rounded and at least 1, so a smaller image
    is the same shot, not a stretched one (as ``usdrecord --imageWidth`` takes the height from the camera); neither:
    ``DEFAULT_WIDTH x DEFAULT_HEIGHT``."""
    if width is None and height is None:
        return DEFAULT_WIDTH, DEFAULT_HEIGHT
    aspect = (camera.image_aspect() if camera is not None else None) or DEFAULT_WIDTH / DEFAULT_HEIGHT
    if height is None:
        return width, max(1, round(width / aspect))
    if width is None:
        return max(1, round(height * aspect)), height
    return width, height


def resolve_view(scene: Scene, camera=None, width: int | None = None, height: int | None = None, settings=None):
    """``(camera, width, height)`` a render of ``scene`` uses: each of ``camera``, ``width`` and ``height`` that is
    given, else the stage's render settings' (``settings``, by default ``Scene.render_settings``: its camera, its
    resolution), else wrt's default (:func:`resolve_camera`, :func:`default_image_size`). A stage camera
    (``None`` or a prim path) then takes the settings' conform policy, pixel aspect ratio, depth of field and data
    window (which may make the image smaller: the pixels inside it); the camera wrt makes to frame a stage without
    cameras takes the data window only (its film is wrt's, not the stage's); a :class:`Camera` object is used as it
    is."""
    settings = scene.render_settings if settings is None else settings
    if settings is None:
        cam = resolve_camera(scene, camera)
        framed = not isinstance(camera, Camera) and not cam.path  # wrt's own camera: 4:3, its square film expanded
        return (cam, *default_image_size(None if framed else cam, width, height))
    width, height = settings.image_size(width, height)
    if camera is None and settings.camera is not None:
        if settings.camera in scene.skipped_cameras:
            raise SceneError(f"{settings.product or settings.path} renders camera {settings.camera}, which wrt cannot "
                             f"use: {scene.skipped_cameras[settings.camera]}", path=settings.source)
        if settings.camera not in scene.cameras:  # a camera wrt skips (one inside a PointInstancer prototype)
            raise SceneError(f"camera {settings.camera} is not among the cameras wrt reads: "
                             f"{', '.join(scene.cameras) or 'none'}", path=settings.source or None,
                             prim=settings.product or settings.path)  # settings made in Python have no source
        camera = settings.camera
    cam = resolve_camera(scene, camera)
    if isinstance(camera, Camera):
        return cam, width, height
    if not cam.path:  # made by wrt to frame the scene: the image is still the shot's, data window included
        return settings.crop(cam, width, height)
    return settings.frame(cam, width, height)


def view_summary(settings, camera: Camera, width: int, height: int, given_camera=None, given_width: int | None = None,
                 given_height: int | None = None) -> str:
    """The words of a view on a stage with render ``settings``: ``camera`` (drawn, :func:`resolve_view`'s) and the
    image's ``width x height``, each with where it came from: the ``given_*`` values (named by ``wrt render``'s
    options), or the settings (the first product's, merged, as :func:`resolve_view` takes them); e.g. ``camera
    /Cam (render settings), 64x32 (resolution of /Render/Product)``. Said by ``wrt render`` for one image and for
    each view of its ``--frames`` (:attr:`wrt.animation.FrameRenderer.log`)."""
    source = settings.product or settings.path
    if given_camera is not None:
        shot = f"{given_camera.label()} (camera object)" if isinstance(given_camera, Camera) else \
            f"camera {given_camera} (--camera)"
    elif settings.camera is not None:
        shot = f"camera {settings.camera} (render settings)"
    else:
        shot = f"camera {camera.path} (the stage's first)" if camera.path else "a camera framing the scene"
    full_w, full_h = settings.image_size(given_width, given_height)
    given = [name for name, value in (("--width", given_width), ("--height", given_height)) if value is not None]
    why = {0: f"resolution of {source}", 1: f"{', '.join(given)}, aspect of {source}", 2: "--width, --height"}
    size = f"{full_w}x{full_h} ({why[len(given)]})"
    if (width, height) != (full_w, full_h):
        size += f", {width}x{height} inside the dataWindowNDC of {source}"
    return f"{shot}, {size}"


def view_window(scene: Scene, camera, width: int | None, height: int | None) -> tuple[int, int, int, int] | None:
    """:attr:`Image.window` of the image :func:`resolve_view` gives for these arguments: the shot's size and the
    image's top-left pixel in it where the render settings' data window crops it (a stage camera, or the camera that
    frames a stage without cameras); ``None`` where the image is the whole shot."""
    settings = scene.render_settings
    if settings is None or isinstance(camera, Camera) or settings.data_window == FULL_WINDOW:
        return None
    return settings.placement(*settings.image_size(width, height))


def _check_one_size(views: list, width: int, height: int) -> None:
    """Raises ValueError unless every ``(camera, width, height)`` of ``views`` (:func:`resolve_view`) is of
    ``width x height``: under the render settings' data window a stage camera's image is the cropped one and a
    :class:`Camera` object's the whole one."""
    if any(view[1:] != (width, height) for view in views):
        raise ValueError("the render settings' dataWindowNDC crops the stage's cameras but not wrt.Camera objects: "
                         "give cameras of one kind")


def shading_data(scene: Scene, device) -> tuple:
    """``(DeviceMaterials, uvs, materials, double_sided, emission estimates, glow bounds)`` of ``scene`` on ``device``
    (:func:`wrt.radiance_scale.glow_bounds`), cached."""
    key = ("shading", str(device))
    if key not in scene._cache:
        images = scene_images(scene.textures)  # checked and made RGBA float32: they may be built in Python
        mats = upload_materials(scene.materials, images, device)
        uvs = scene.corner_uvs()
        tri_materials = scene.triangle_materials()
        sided = scene.triangle_double_sided().astype(np.int32)
        if len(tri_materials) == 0:  # keep arrays non-empty so kernels can bind them
            uvs, tri_materials, sided = np.zeros((1, 3, 2), np.float32), np.zeros(1, np.int32), np.ones(1, np.int32)
        arrays = (
            wp.array(uvs, dtype=wp.vec2, device=device),
            wp.array(tri_materials, dtype=wp.int32, device=device),
            wp.array(sided, dtype=wp.int32, device=device),
        )
        scene._cache[key] = (mats, *arrays, emission_estimates(scene.materials, images),
                             glow_bounds(scene.materials, images))
    return scene._cache[key]


class _Wavefront:
    """Per-path device arrays for ``n`` paths; :meth:`view` gives the first ``m`` of them."""

    FIELDS: ClassVar[dict] = {
        "origins": wp.vec3,
        "directions": wp.vec3,
        "t_mins": float,
        "t_maxs": float,
        "rng": wp.uint32,
        "throughput": wp.vec3,
        "radiance": wp.vec3,
        "alive": wp.int32,
        "pdf_prev": float,
        "prev_normal": wp.vec3,
        "diffuse_share": wp.vec3,  # path: the diffuse lobe's share of the last bounce's weight (emitters.scattered_by)
        "link_groups": wp.int32,  # link group of the surface that scattered the ray (light_links; emitters.reaches)
        "shadow_origins": wp.vec3,
        "shadow_dirs": wp.vec3,
        "shadow_t_maxs": float,
        "shadow_lights": wp.int32,  # the light of each shadow ray (-1: none), for shadow linking
        "blocked": wp.int32,
        "nee": wp.vec3,
        "views": wp.int32,  # the camera of each path (for the default headlight)
    }

    def __init__(self, n: int, device, nothing_to_cull: bool, no_holes: bool):
        self.n = n
        self.device = device
        for name, dtype in self.FIELDS.items():
            setattr(self, name, wp.empty(n, dtype=dtype, device=device))
        self.shadow_t_mins = wp.zeros(n, dtype=float, device=device)
        self.hits = HitBuffer(n, device)
        self.scratch = CullScratch(n, device, nothing_to_cull, no_holes)
        self.counter = wp.zeros(1, dtype=wp.int32, device=device)
        self.owner = self  # the wavefront whose buffers a view shares
        self.batch = None  # ShadowRays of several lights per path (shadow_rays), made on first use

    @classmethod
    def bytes_per_path(cls) -> int:
        """Device bytes :meth:`__init__` allocates per path: the fields, ``shadow_t_mins``, the hits and the cull
        scratch (a ray range and hits of its own)."""
        fields = sum(wp.types.type_size_in_bytes(t) for t in cls.FIELDS.values()) + 4
        return fields + HitBuffer.BYTES_PER_RAY + CullScratch.BYTES_PER_RAY

    def view(self, m: int) -> _Wavefront:
        if m == self.n:
            return self
        v = object.__new__(_Wavefront)
        v.n, v.device, v.counter, v.owner = m, self.device, self.counter, self.owner
        for name in list(self.FIELDS) + ["shadow_t_mins"]:
            setattr(v, name, getattr(self, name)[:m])
        v.hits = self.hits.slice(0, m)
        v.scratch = self.scratch.head(m)
        return v

    @property
    def rays(self) -> list:
        return [self.origins, self.directions, self.t_mins, self.t_maxs]

    def shadow_rays(self, lights: int = 1) -> ShadowRays:
        """The shadow rays of ``lights`` lights per path, ray ``j * n + i`` light ``j``'s of path ``i``: for one
        light the wavefront's own arrays, for more buffers kept with it (grown when too small)."""
        if lights == 1:
            return ShadowRays.of(self.shadow_origins, self.shadow_dirs, self.shadow_t_mins, self.shadow_t_maxs,
                                 self.shadow_lights, self.blocked, self.nee, self.scratch)
        m, owner = lights * self.n, self.owner
        if owner.batch is None or owner.batch.n < m:
            owner.batch = ShadowRays(m, self.device, self.scratch.nothing_to_cull, self.scratch.no_holes)
        return owner.batch.head(m)


def used_anywhere(marked: np.ndarray, materials: np.ndarray) -> bool:
    """Whether any of the ``(T,)`` device ``materials`` of the triangles is ``marked`` (``(M,)`` bool per device
    material); none marked is answered without a look at the triangles, which took 1 ms per question and million
    triangles at every Renderer."""
    return bool(marked.any() and marked[materials].any())


def launch_per_path(kernel, n: int, inputs: list, outputs: list, device) -> None:
    """``wp.launch`` of a kernel whose thread ``i`` touches only entry ``i`` of its length-``n`` arrays; on the CPU
    the launch is split into pieces run on a thread pool (Warp runs one CPU launch on one thread)."""

    def work(start: int, end: int):
        def piece(x):
            return (x[start:end] if isinstance(x, wp.array) and x.ndim == 1 and len(x) == n and (start, end) != (0, n)
                    else x)

        wp.launch(kernel, end - start, inputs=[piece(x) for x in inputs], outputs=[piece(x) for x in outputs],
                  device=device)

    run_in_chunks(work, n, resolve_threads(None, device), [kernel])  # one piece on a GPU


def held_values(values) -> tuple:
    """``values`` and, for each Warp struct among them, its fields (recursively): what a recorded graph must keep.
    A struct's array may be replaced while the struct stays (``set_cameras`` with another camera count gives
    ``DeviceLights`` a new headlight array), and the old one, which an older graph reads, was freed."""
    held = []
    for value in values:
        held.append(value)
        if wp.types.is_struct(value):
            held.extend(held_values(vars(value).values()))
    return tuple(held)


def capturing_graph(device) -> wp.Graph | None:
    """The :class:`wp.Graph` that ``device`` is recording now, or None: Warp keeps a CUDA capture's graph per stream
    (``Device.captures``) and a CPU capture's in its runtime, and has no public call that returns it."""
    device = wp.get_device(device)
    if device.is_cuda:
        return device.captures.get(device.stream)
    try:
        from warp._src import context as warp_context
    except ImportError:  # another Warp layout: the caller keeps what the graph reads itself
        return None
    graph = getattr(getattr(warp_context, "runtime", None), "_apic_graph", None)
    return graph if graph is not None and graph.device == device else None


SHORT_REPRS = ("integrator", "max_depth", "ao_radius", "width", "height", "device", "batched")  # shown when assigned


def one_call_at_a_time(method):
    """A :class:`Renderer` method that holds the renderer's lock: its path, image and frame buffers are shared by
    its calls, and two threads rendering with one Renderer at once wrote their paths into each other's buffers, both
    images of neither render, without a word. Reentrant, as these methods call each other. A call that reads the
    scene takes the scene's lock first thing (:meth:`Renderer._scene_turn`)."""

    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        me = threading.get_ident()
        try:
            # Inside the try: Python raises a Ctrl-C that comes as the wait ends at the acquire's return, the lock
            # taken; taken before the try, it stayed held by the interrupted thread, and every later call waited.
            self._calls.acquire()
            self._calls_owner = me
            self._calls_held += 1
            return method(self, *args, **kwargs)
        finally:
            # Not where its wait to take the lock back (_scene_turn) was interrupted (Ctrl-C): it holds nothing then,
            # and released the lock of no call, or another thread's ('cannot release un-acquired lock' in place of
            # the interrupt), leaving the count at -1: every later first call waited as a nested one (_scene_turn).
            if self._calls_owner == me:
                self._calls_held -= 1
                if self._calls_held == 0:
                    self._calls_owner = None
                self._calls.release()
            elif self._calls._is_owned():  # taken (here or in _scene_turn) but interrupted before it was counted
                self._calls.release()

    return locked


def read_only(name: str, why: str, instead: str | None = None) -> property:
    """A :class:`Renderer` attribute (a setting, its scene, cameras, device or lights) read as any other but refused
    when assigned, naming what to do instead: each is baked into the buffers, the camera structs, the lights or a
    recorded graph, so that an assignment would go unseen (``renderer.integrator = "pth"`` would draw a black image,
    ``renderer.width = 4`` the old camera's rays into a narrower image). ``why``: why it is fixed; ``instead``:
    what to do, where it is not a new Renderer of the same scene with this setting."""
    instead = instead or f"make a new wrt.Renderer(scene, {name}=...) instead (it reuses the scene's BVH)"

    def refuse(self, value):
        shown = repr(value) if name in SHORT_REPRS else f"{type(value).__name__} object"  # a Scene's repr is long
        raise AttributeError(f"Renderer.{name} cannot be assigned ({name}={shown}): {why}; {instead}")

    return property(lambda self: getattr(self, f"_{name}"), refuse, doc=f"{why} (read-only).")


def check_lights(lights) -> None:
    """Runs the constructor's checks of each light (and of its shaping and link collections) again: a field assigned
    after construction (``light.color = (nan, 1, 1)``, ``light.radius = -1``, a step's new value) lit the scene
    wrongly, or not at all, without a word.

    Raises:
        SceneError: naming the light and the field.
    """
    check_light_types(lights)  # one appended to scene.lights since the Scene was made
    for light in lights:
        check_folded_inputs(light)  # light.intensity = 2: no field of wrt's lights
    for part in dataclass_parts(lights):
        if dataclass_field_names(type(part)) is not None and hasattr(part, "__post_init__"):
            part.__post_init__()


def check_lights_as_recorded(lights: list, parts: tuple) -> tuple:
    """:func:`check_lights` of ``lights``, whose record (:func:`wrt.scene.dataclass_parts`) was ``parts`` before the
    check; returns the record of the lights as checked, taken after the check (which may give a field its array) where
    nothing else changed during it. A light's fields are assigned without the scene's lock: recorded after the check
    alone, a NaN colour given by another thread between the two was recorded as checked, and a kept Renderer drew it
    at every render (its samples dropped as not finite) where a new one refused it. A light changed during the check
    is checked again; where the lights keep changing, the record before the last check is returned, so that the next
    render sees the change and checks it."""
    for _ in range(3):
        check_lights(lights)
        checked = tuple(dataclass_parts(lights))
        if not parts_changed(parts, checked):
            return checked
        before, parts = parts, checked
    return before


def not_a_camera_list(cameras) -> bool:
    """Whether ``cameras`` cannot be a list of cameras: a single path or camera given where a list belongs (a path
    was read one character at a time: "no camera at '/'"), a mapping (its keys were read as prim paths), or no
    iterable at all."""
    return isinstance(cameras, (str, Camera, Mapping)) or not hasattr(cameras, "__iter__")


def camera_list(cameras) -> list:
    """``cameras`` (a list, a tuple, a generator: any iterable of prim paths or :class:`Camera`) as a list, as
    :func:`wrt.render_batch` takes them; a generator was refused here ("must be a list"). Raises ValueError where
    :func:`not_a_camera_list`, or for no camera at all."""
    if not_a_camera_list(cameras):
        raise ValueError(f"cameras must be a list of cameras (prim paths or wrt.Camera), got {cameras!r}; for one "
                         "camera, give camera= or a list of one")
    cameras = list(cameras)
    if len(cameras) == 0:
        raise ValueError("cameras is empty: give at least one camera")
    return cameras


def resolve_views(scene: Scene, cameras: list, width: int | None, height: int | None) -> list:
    """:func:`resolve_view` of each of ``cameras``; an entry of no camera kind (``5``) is named by its index."""
    views = []
    for k, camera in enumerate(cameras):
        try:
            views.append(resolve_view(scene, camera, width, height))
        except TypeError as error:
            raise TypeError(f"cameras[{k}] of {len(cameras)}: {error}") from None
        if scene.render_settings is None:  # one image size: a side not given follows the first camera's aspect
            width, height = views[0][1:]
    return views


def camera_structs(cameras: list, width: int, height: int, batched: bool) -> list:
    """The :class:`DeviceCamera` of each of ``cameras`` for ``width x height`` images, each camera checked again
    (:meth:`Camera.check`: its fields may have been set since it was made); in a batch (``batched``) the message
    of a bad camera names its index, which its own label (``camera``, for one made in Python) did not give."""
    structs = []
    for k, camera in enumerate(cameras):
        try:
            structs.append(camera.to_struct(width, height))
        except ValueError as error:
            if not batched:
                raise
            raise ValueError(f"cameras[{k}] of {len(cameras)}: {error}") from None
    return structs


class Renderer:
    """Renders one scene from one camera at one resolution with one integrator; reusable across calls and seeds.

    ``__init__`` resolves the camera, builds (or reuses) the accelerator and uploads materials and lights;
    ``render()`` only allocates path buffers (once per batch size) and launches kernels. The wall time of each
    stage's last run lands in ``timers`` (``timers["build"]``, ``timers["render"]``: a list of one entry, in
    milliseconds, as ``wp.ScopedTimer`` records them); earlier runs are not kept, so a long loop holds no history.

    Args:
        scene: the scene to render.
        camera: a :class:`Camera`, a camera prim path, or ``None`` (see :func:`resolve_view`: the stage's render
            settings choose it, and frame stage cameras).
        width: image width in pixels; ``None``: the render settings' resolution, else 640 (else the camera's aspect
            of ``height``: :func:`default_image_size`).
        height: image height in pixels; ``None``: the render settings' resolution, else 480 (likewise).
        device: Warp device; Warp's default device when ``None``.
        builder: BVH builder name.
        accel: ``"wrt"`` or ``"warp"``.
        integrator: one of :data:`wrt.integrators.INTEGRATORS` (see the README): ``"whitted"``, ``"path"``,
            ``"ao"``, ``"normals"``, ``"depth"`` or ``"albedo"``.
        max_depth: surface interactions per path (``path``) or mirror/refraction bounces (``whitted``); default
            from :data:`DEFAULT_MAX_DEPTH`.
        cameras: instead of ``camera``, a list of cameras (each as ``camera`` takes them) rendered together in one
            launch per pass; :meth:`render` then returns a :class:`BatchImage`. Without lights in the stage, the
            default headlight of each camera travels along its viewing direction, as in a render of that camera
            alone.
        ao_radius: occlusion distance of ``ao`` in scene units; default a tenth of the scene's bounding-box
            diagonal, measured again whenever the renderer builds again for an edited scene.

    The settings (``integrator``, ``max_depth``, ``ao_radius``, ``width``, ``height``) are read-only attributes
    (:func:`read_only`): make a new Renderer for others; it reuses the scene's BVH. So is ``scene``: a Renderer
    follows the edits of its scene, and another scene takes a new Renderer; and so are ``device``, ``batched``,
    ``camera`` and ``cameras``, which :meth:`set_cameras` sets.

    Each render follows the cameras as a new Renderer would take them: a :class:`Camera` given and edited since (a
    field set, ``to_world`` edited in place), the scene's camera at the path given replaced or edited, the camera
    wrt makes to frame a stage without cameras after a scene edit, and render settings replaced; the image takes the
    size a new Renderer would (a camera's new aspect where one side was not given, the settings' new resolution or
    data window). ``camera`` and ``cameras`` are the views drawn: a :class:`Camera` given is its own view, but a stage
    camera under render settings (given the settings' film) and the camera that frames a stage without cameras are
    views the renderer made, not cameras it follows: an edit of one is not drawn, and the next render warns, naming it.
    """

    # Its BVH, device data, lights and recorded graphs are of it: another scene assigned was drawn with the old one's
    # where their edit counts matched, and crashed the rebuild otherwise.
    scene = read_only("scene", "the scene is the one the Renderer was made for (edits of it are followed)",
                      "make a new wrt.Renderer(other_scene, ...) for another scene")
    # Uploaded where they are set (set_cameras): renderer.camera = other drew the old camera without a word, and a
    # longer cameras list read the image sums past their end.
    camera = read_only("camera", "the cameras drawn are uploaded by set_cameras; an edit of a wrt.Camera given "
                       "(a field set, to_world edited) is followed", "call set_cameras([camera]) instead")
    cameras = read_only("cameras", "the cameras drawn are uploaded by set_cameras; an edit of a wrt.Camera given "
                        "(a field set, to_world edited) is followed", "call set_cameras(cameras) instead")
    device = read_only("device", "the buffers, BVH and recorded graphs are on the device the Renderer was made on")
    batched = read_only("batched", "a renderer of cameras= (or after set_cameras) returns BatchImages",
                        "make a new wrt.Renderer(scene, camera=...) for an Image")
    integrator = read_only("integrator", "the integrator is chosen when the Renderer is made")
    max_depth = read_only("max_depth", "the bounce limit is chosen when the Renderer is made")
    ao_radius = read_only("ao_radius", "the occlusion distance is the one given when the Renderer was made, "
                          "else the scene's (measured again after each scene edit)")
    width = read_only("width", "the image width is the one given when the Renderer was made, else the render "
                      "settings' or the camera's (followed at each render)")
    height = read_only("height", "the image height is the one given when the Renderer was made, else the render "
                       "settings' or the camera's (followed at each render)")
    # The lights uploaded at the last build, a tuple: appended to or assigned, a list drew nothing new without a word.
    lights = read_only("lights", "the lights drawn are scene.lights (or the default lights of a stage without "
                       "any), uploaded at each render after an edit", "edit scene.lights instead")

    def __init__(
        self,
        scene: Scene,
        *,
        camera=None,
        width=None,
        height=None,
        device=None,
        builder="sah",
        accel="wrt",
        integrator="whitted",
        max_depth=None,
        ao_radius=None,
        cameras=None,
    ):
        self._calls = threading.RLock()  # held by each render, frame and camera upload (one_call_at_a_time)
        self._calls_held = 0  # how many calls the thread holding it is in (one_call_at_a_time, _scene_turn)
        self._calls_owner = None  # the thread holding it (threading.get_ident), None while none does
        check_scene(scene)
        check_sides(width, height)
        if cameras is not None:
            if camera is not None:
                raise ValueError("give either camera or cameras, not both")
            cameras = camera_list(cameras)
        self._scene = scene
        self._asked_size = (width, height)  # as given: set_cameras frames new stage cameras at it
        scene.drop_stale_caches()  # before the first cached read: the bounds frame the default camera
        views = [resolve_view(scene, camera, width, height)] if cameras is None else resolve_views(scene, cameras,
                                                                                                   width, height)
        # Where each camera's image is a crop of its shot (Image.window): stage cameras under a data window.
        self._windows = [view_window(scene, c, width, height) for c in ([camera] if cameras is None else cameras)]
        width, height = views[0][1:]
        _check_one_size(views, width, height)
        check_asked_pixels(scene, width, height, len(views), self._asked_size)
        if integrator not in INTEGRATORS:
            raise ValueError(f"unknown integrator {integrator!r}{did_you_mean(integrator, INTEGRATORS)}; valid "
                             f"integrators: {', '.join(INTEGRATORS)}")
        warn_unused_integrator_options(integrator, max_depth, ao_radius)
        if max_depth is None:
            max_depth = DEFAULT_MAX_DEPTH.get(integrator, 1)
        integral = isinstance(max_depth, (int, np.integer)) and not isinstance(max_depth, bool)
        if not (integral and 0 <= max_depth <= MAX_DEPTH):
            raise ValueError(f"max_depth must be an integer from 0 to {MAX_DEPTH}, got {max_depth!r}")
        if ao_radius is not None and (isinstance(ao_radius, bool) or not (
            isinstance(ao_radius, (int, float, np.integer, np.floating)) and math.isfinite(ao_radius) and ao_radius > 0
        )):
            raise ValueError(f"ao_radius must be a positive number, got {ao_radius!r}")
        self._width, self._height = int(width), int(height)
        self._cameras = tuple(view[0] for view in views)  # a tuple: appended to, it was drawn with unuploaded cameras
        self._camera = self._cameras[0]
        self._batched = cameras is not None
        self._device = resolve_device(device)
        self._integrator = integrator
        self._max_depth = int(max_depth)
        self._asked_ao_radius = ao_radius  # None: the scene's, measured again at each build (_build)
        self.timers = {}
        stats = scene.stats()
        triangles = stats["rendered_triangles"]
        # Triangles that all have zero area (collinear or repeated corners) can no more be hit than none at all.
        flat = triangles and not any(has_area(m.points, m.indices) for m in scene._geometry_meshes())
        if (triangles == 0 or flat) and stats.get("rendered_shapes", 0) == 0:
            # A dome, a soft sun or an area light alone is what the camera sees (an HDRI or light preview): said only
            # where nothing at all can appear.
            lit = integrator in LIGHT_SAMPLING_INTEGRATORS
            if not (lit and any(map(seen_by_camera, scene.lights))):
                lights = ("" if not scene.lights else f", and the {integrator} integrator shows no light" if not lit
                          else ", and no light a camera ray sees")
                what = (f"its {counted(triangles, 'triangle')} all have zero area (collinear or repeated corners), so "
                        "no ray can hit one" if flat else "no triangles")
                warnings.warn(f"{scene.source or 'scene'}: nothing to render ({what}{lights}); the image is "
                              "background only", stacklevel=user_stacklevel())
        self._accel_options = (accel, builder)
        self._sync_free = False  # launch every bounce, read nothing back (launch_frame)
        # Non-finite samples left out of the image the last render returned (or the frame that frame_image read):
        # with resume=True, of all the samples that image adds up, as one render of them all would count.
        self.dropped_samples = 0
        self._camera_args = [camera] if cameras is None else cameras  # as given: followed at each render
        # Why the last sums were dropped, for resume's warning (None: never): a later drop with no sums left (a
        # scene edit's rebuild after a set_cameras) keeps it; it said nothing then.
        self._sums_dropped, self._progressive = None, None
        self._sides = self._asked_size  # the sides that size the image without render settings (set_cameras pins them)
        # launch_frame's buffers are numbered as made; each frame writes its number here, into one array that outlives
        # them, so that frame_image can tell a replayed graph recorded with buffers dropped since (a scene edit's
        # rebuild, a new size or camera count): it drew into those, and frame_image showed the last frame drawn here.
        self._frames_made = 0
        self._frame_number = wp.zeros(1, dtype=wp.int32, device=self.device)
        # Each camera upload is numbered, its number kept on the device beside the cameras; a frame copies it (in
        # what a graph records), so that frame_image can tell a frame drawn before the cameras last changed: a frame
        # drawn, then set_cameras (or an edited camera that render() uploaded), returned the old poses without a word.
        self._camera_uploads = 0
        self._camera_upload_number = wp.zeros(1, dtype=wp.int32, device=self.device)
        self._recorded = ()  # what the last recorded graph reads, where Warp's graph cannot keep it (launch_frame)
        # Warnings said once, by key: the far-view and clipped-away ones (wrt.far_views, warn_clipped_away), which
        # every camera upload (set_cameras each step of a simulation, a rebuild) repeated, and those of each image
        # (_warn_once), which a loop of frames gave at every frame. Shared by the Renderers of a loop of wrt.render
        # calls (shown_for_scene): their words name the scene's extent, a camera's distance or a count, which change
        # each frame. A FrameRenderer gives each frame's Renderer a set of its own (every warning of the frame is in
        # its log row) and says each once over the frames itself, by the same keys.
        self._said_once = shown_set()
        # Before the build uploads the cameras (_follow_cameras): a camera moved by another thread during the build was
        # recorded at its new pose, and every render drew the pose uploaded.
        key = self._camera_sources_key()
        self._build()
        self._camera_key = key
        self._note_views()
        self._warn_clipped_away()

    def __repr__(self) -> str:
        # The default repr, '<wrt.render.Renderer object at 0x...>', was all a notebook cell ending in one showed.
        views = counted(len(self.cameras), "camera") if self.batched else self.camera.label()
        source = f"{self.scene.source!r}" if self.scene.source else "scene"
        return (f"Renderer({source}, {self.width}x{self.height}, {views}, integrator={self.integrator!r}, "
                f"device={str(self.device)!r})")

    def _build(self) -> None:
        """The accelerator, device scene, shading data and lights of the scene as it is now; buffers made anew."""
        with self.scene.lock:  # of one state of the scene: a cache drop from another thread waits (Scene.lock)
            self._build_locked()

    def _build_locked(self) -> None:
        """:meth:`_build`, with the scene's lock held."""
        # What is drawn is recorded as it is before the build reads it: a light appended by another thread in the
        # middle of the build (no lock needed to append) was recorded as drawn and never uploaded.
        self.scene.drop_stale_caches()
        generation = self.scene.cache_generation
        lights, dark = tuple(dataclass_parts(self.scene.lights)), bool(self.scene.dark_lights)
        # Lights are checked again when one was replaced or given a new field, and after scene.invalidate(), which
        # makes their arrays writeable: a NaN written into a light's colour then drew a kept Renderer's image black
        # without a word, where a new render refused it.
        if generation != getattr(self, "_scene_generation", None) or parts_changed(
            getattr(self, "_scene_lights", ()), lights
        ):
            lights = check_lights_as_recorded(self.scene.lights, lights)
        # The default ao_radius follows the scene as the BVH does: a kept Renderer kept the radius of the scene it was
        # made for, and after a mesh was added far away its ao image differed from a fresh render's.
        self._ao_radius = float(self._asked_ao_radius or self._scene_ao_radius())
        with self._timer("build"):
            self.accel = get_accelerator(self.scene, *self._accel_options, self.device)
            self.device_scene = self.scene.to_device(self.device)
            self._upload_shading()
        # The ids of the scene built, for every image drawn until the next build: read at each render, after the lock,
        # instances given other prototypes by another thread meanwhile had the image's ids (and its misses) expanded
        # by the new ones. Not copied here (20 MB per build at 5M instances, a build per frame of moving instances):
        # what outlives the call (sums, a BatchImage) takes a copy (IdRows.copied).
        self._id_rows = self.scene.id_rows(copy=False)
        self._scene_generation = generation
        stats = self.scene.stats()  # (counted here, not at each camera change: set_cameras may come every step)
        self._draws_anything = bool(stats["rendered_triangles"] or stats.get("rendered_shapes", 0))
        self._scene_lights = lights
        self._dark = dark  # what decides the default lights, with the lights (_upload_shading)
        self.scene.freeze(self._scene_lights)  # a light's array edited in place went unseen, as a mesh's did
        self._wavefront = None
        self._frame = None  # buffers of launch_frame
        # Running sums of the last render, for render(resume=True); a rebuild for an edited scene drops them.
        self._drop_sums("the scene changed")

    def _timer(self, stage: str) -> wp.ScopedTimer:
        """A synchronizing timer of ``stage`` whose milliseconds replace the last run's in ``timers[stage]``:
        appended at every render and rebuild, the lists grew without bound over a long loop."""
        self.timers[stage] = []
        return wp.ScopedTimer(stage, print=False, dict=self.timers, synchronize=True)

    def _scene_ao_radius(self) -> float:
        """A tenth of the scene's bounding-box diagonal (1 for an empty scene): the default ``ao_radius``."""
        lower, upper = self.scene.bounds()
        return 0.1 * float(np.linalg.norm(np.asarray(upper, np.float64) - lower)) or 1.0

    def _follow(self) -> None:
        """:meth:`_follow_scene`, then :meth:`_follow_cameras`; a rebuilt scene's clipping warnings after both: a
        camera wrt frames follows the moved scene only in the second, and warned with its old framing that it 'sees
        nothing' of the scene it then drew. First thing in its call: the scene's turn (:meth:`_scene_turn`)."""
        with self._scene_turn():
            rebuilt = self._follow_scene()
            self._follow_cameras()
            if rebuilt:
                self._warn_clipped_away()  # the scene may have moved out of a camera's clipping range

    @contextlib.contextmanager
    def _scene_turn(self):
        """The scene's lock (:attr:`Scene.lock`), taken by a call (:func:`one_call_at_a_time`) that reads the scene
        before it has changed anything. Where another thread holds it, the call lets go of the renderer's lock until
        the scene's is free: that thread may be waiting for this renderer (``renderer.set_cameras(...)`` inside
        ``with scene.lock:`` while another thread's render waited for the scene's lock holding the renderer's: each
        waited for the other for good). Past its turn a call takes the scene's lock only where it holds it already,
        so that a thread holding it never waits for a call that waits for it."""
        lock = self.scene.lock
        if self._calls_held == 1:  # (a call made inside another of this thread's, which has begun its work, waits)
            while not lock.acquire(blocking=False):
                self._calls_held, self._calls_owner = 0, None
                self._calls.release()
                try:
                    with lock:  # the thread holding it goes first, with this renderer where it asks for it
                        pass
                finally:
                    self._calls.acquire()
                    self._calls_held, self._calls_owner = 1, threading.get_ident()
        else:
            lock.acquire()
        try:
            yield
        finally:
            lock.release()

    def _follow_scene(self) -> bool:
        """Builds again when the scene changed since the last build (a mesh, material, light or instance array
        replaced, or ``scene.invalidate()`` after an edit in place), as a trace would: a kept Renderer drew the old
        geometry. True where it built again."""
        with self.scene.lock:  # the check and the build of one state of the scene (Scene.lock)
            return self._follow_scene_locked()

    def _follow_scene_locked(self) -> bool:
        """:meth:`_follow_scene`, with the scene's lock held."""
        if self._scene_changed():
            if wp.get_device(self.device).is_capturing:  # a build's uploads cannot be recorded into a CUDA graph
                raise RuntimeError("the scene changed since the renderer was built: call launch_frame() once "
                                   "outside the capture, then record the frame again")
            check_scene(self.scene)
            self._build()
            return True
        return False

    def _scene_changed(self) -> bool:
        """Whether the scene changed since the last build (:meth:`_follow_scene`)."""
        self.scene.drop_stale_caches()
        # Lights are compared with their fields: a light given a new colour or intensity (light.color = ...) kept
        # shining with the old one.
        lights = tuple(dataclass_parts(self.scene.lights))
        for light in self.scene.lights:  # light.exposure = 2 adds no field: the record above does not change
            check_folded_inputs(light)
        # scene.dark_lights set alone (the last light listed as hidden) kept or left out the default lights wrongly.
        dark = bool(self.scene.dark_lights) != self._dark
        edited = self.scene.cache_generation != self._scene_generation
        return edited or parts_changed(self._scene_lights, lights) or dark

    def _warn_clipped_away(self) -> None:
        """:func:`warn_clipped_away` for the renderer's cameras, where the scene draws anything; each message once.
        Called whenever the cameras or the scene change: a camera given by set_cameras, or edited since, that sees
        nothing drew background without a word, where a new Renderer warned."""
        if self._draws_anything:
            warn_clipped_away(self.scene, self.cameras, self._said_once)

    def _camera_sources_key(self, camera_args=None) -> tuple:
        """What the renderer's cameras (or ``camera_args``, as given to :meth:`set_cameras`) are made from, as it is
        now: each camera given, or the scene's camera at its path, with its fields (:meth:`Camera.snapshot`); the
        scene's edit count where wrt frames the scene."""
        # id(source) may be reused by a camera made after the old one was freed, but the key is then unchanged only
        # where the snapshot is too, i.e. every field (the whole view) is the same: a reused id never hides a change.
        # The render settings (frozen: replaced, never edited) choose the camera, the image size and the data window;
        # settings replaced by others of another product name alone keep the view, and resume=True's sums with it.
        key = [self._settings_view()]
        for arg in self._camera_args if camera_args is None else camera_args:
            source = camera_source(self.scene, arg)
            # wrt frames the scene by its bounds and along its up_axis (a plain field, assigned without an edit count)
            framed = ("framed", self.scene.cache_generation, self.scene.up_axis)
            key.append(framed if source is None else (id(source), source.snapshot()))
        return tuple(key)

    def _camera_changes(self) -> str:
        """What changed in the cameras since they were uploaded (:meth:`_camera_sources_key`), in words for an
        error (``camera /Cam (to_world, focal_length)``, ``cameras[1] of 2 (f_stop)``), or ``""`` where nothing did."""
        now = self._camera_sources_key()
        if now == self._camera_key:
            return ""
        parts = ["the render settings"] if now[0] != self._camera_key[0] else []
        for k, (arg, old, new) in enumerate(zip(self._camera_args, self._camera_key[1:], now[1:])):
            if old == new:
                continue
            source = camera_source(self.scene, arg)
            path = self._camera_path(arg)
            name = (f"cameras[{k}] of {len(self._camera_args)}" if self.batched else source.label() if source
                    else f"camera {path}" if path else "the camera wrt frames the scene with")
            if source is None:  # framed anew, or a path that names no camera now
                parts.append(f"{name} (gone from scene.cameras)" if path else name)
            elif old[0] == "framed" or old[0] != new[0]:
                parts.append(f"{name} (replaced)")
            else:
                fields = [f for f, a, b in zip(CAMERA_FIELDS, old[1], new[1]) if not a == b]
                parts.append(f"{name} ({', '.join(fields)})")
        return " and ".join(parts) or "the cameras"

    def _camera_path(self, arg) -> str | None:
        """The prim path of the stage camera that ``arg`` (as :func:`resolve_view` takes it) names: a path given (a
        ``str`` or an ``Sdf.Path``) or, for ``None``, the render settings' camera; ``None`` for a :class:`Camera` and
        where wrt picks the camera (the stage's first, or one that frames the scene)."""
        if arg is None:
            settings = self.scene.render_settings
            return None if settings is None else settings.camera
        return None if isinstance(arg, Camera) else str(arg)

    def _note_views(self) -> None:
        """Keeps the fields of each camera of :attr:`cameras` that wrt resolved as a camera of its own (a stage camera
        given the render settings' film, the camera that frames a stage without cameras), with those of its source,
        for :meth:`_edited_views`; a camera that is its own source (a :class:`Camera` given, a stage camera as it is)
        is followed as a source."""
        self._view_snapshots = []
        for cam, arg in zip(self.cameras, self._camera_args):
            source = camera_source(self.scene, arg)
            self._view_snapshots.append(None if cam is source else (cam.snapshot(), source and source.snapshot()))

    def _edited_views(self) -> str:
        """The cameras of :attr:`cameras` that wrt resolved (:meth:`_note_views`) and that were edited since where
        their source was not (a view may share its source's ``to_world``), in words (``renderer.camera
        (to_world)``, ``renderer.cameras[1] (focal_length)``), or ``""``: such an edit changed nothing, as the
        renderer follows the cameras it was given, and it drew the old view without a word."""
        parts = []
        for k, (cam, arg, noted) in enumerate(zip(self.cameras, self._camera_args, self._view_snapshots)):
            if noted is None or noted[0] == (view := cam.snapshot()):
                continue
            source = camera_source(self.scene, arg)
            now = source.snapshot() if source is not None and noted[1] is not None else None
            fields = [f for j, f in enumerate(CAMERA_FIELDS) if not noted[0][j] == view[j]
                      and (now is None or noted[1][j] == now[j])]  # a field its source changed too is followed
            if fields:
                name = f"renderer.cameras[{k}]" if self.batched else "renderer.camera"
                parts.append(f"{name} ({', '.join(fields)})")
        return " and ".join(parts)

    def _settings_view(self) -> tuple | None:
        """The fields of the scene's render settings that choose the image (None without settings)."""
        settings = self.scene.render_settings
        return None if settings is None else settings.view_fields()

    def _follow_cameras(self) -> None:
        """Resolves and uploads the cameras again when one changed since they were uploaded (a field set,
        ``camera.to_world[0, 3] = 2`` in place, a stage camera replaced in ``scene.cameras``, or, for the camera wrt
        makes, a scene edit that moves its bounds), as a new Renderer would: a kept Renderer drew the old view."""
        key = self._camera_sources_key()
        edited = self._edited_views()
        if key == self._camera_key and not edited:
            # Unchanged by value, but a field set to a list of its numbers is made the array an upload made of it.
            sources = (camera_source(self.scene, arg) for arg in self._camera_args)
            for cam in {id(c): c for c in (*self.cameras, *sources) if c is not None}.values():
                cam.hold_checked_arrays()
            return
        if edited:  # said, then drawn as the sources give it: the edit of a view wrt made went unseen, unsaid
            warnings.warn(f"{edited} edited, but that is the view the Renderer resolved, not a camera it follows: the "
                          "edit is not drawn; edit the camera it comes from (scene.cameras[path]) or give a wrt.Camera "
                          "(camera=..., set_cameras)", stacklevel=user_stacklevel())
        if wp.get_device(self.device).is_capturing:  # the uploads cannot be recorded into a CUDA graph
            raise RuntimeError("a camera changed since the renderer last drew: call launch_frame() once outside the "
                               "capture, then record the frame again")
        asked = self._asked_size if self.scene.render_settings is not None else self._sides
        views = resolve_views(self.scene, self._camera_args, *asked)
        # The size follows too, as a new Renderer's: a camera's aspect (where one side was not given) or the render
        # settings' resolution or data window changed. A kept Renderer drew the old size, stretched.
        size = views[0][1:]
        _check_one_size(views, *size)
        check_asked_pixels(self.scene, *size, len(views), asked)
        self._upload_cameras_at([view[0] for view in views], size, self.batched)  # raises naming a bad camera
        self._windows = [view_window(self.scene, c, *asked) for c in self._camera_args]
        # As it was before it was read (by value, so the checks' conversions change nothing): a camera moved by
        # another thread after the upload was recorded as drawn at its new pose, and never uploaded.
        self._camera_key = key
        self._note_views()
        self._drop_sums("a camera changed")  # the sums are of the old view
        self._warn_clipped_away()

    def _warn_unsampled(self, unsampled) -> None:
        """Names, in one warning, the emitters that the integrator shows but does not sample as lights: the emissive
        triangles and glowing spheres, tubes and hulls of instances past the cap on sampled instanced emitters
        (``unsampled``: :class:`wrt.light_table.UnsampledEmitters`), under every integrator that samples lights, and
        under whitted its ``shapes``, emissive analytic shapes that are not sampled (those a transform squashes flat,
        whose ellipsoid has no float32 inverse: wrt.glowing_spheres; boxes, ellipsoids, elliptic tubes and shapes
        that glow inwards are sampled as hulls, wrt.glowing_hulls; a stage's emissive gprims are drawn as
        triangles, wrt.usd), which path finds by the rays that hit them."""
        parts = [text for text in [unsampled.describe()] if text]
        if self.integrator == "whitted" and unsampled.shapes:
            parts.append(f"{int(unsampled.shapes)} emissive analytic primitive(s)")
        if not parts or self.integrator not in LIGHT_SAMPLING_INTEGRATORS:
            return
        if self.integrator == "whitted":
            effect = ("the whitted integrator shows them but they light nothing; use integrator='path' (wrt render: "
                      "--integrator path), or draw them as world-space meshes (wrt.primitives.tessellate for a Shape)")
        else:
            effect = ("they light the scene only through the rays that happen to hit them, so their light is noisier; "
                      f"the cap is wrt.light_table.MAX_INSTANCED_EMITTERS ({unsampled.cap:,})")
        warnings.warn(f"{self.scene.source or 'scene'}: {' and '.join(parts)} are not sampled as lights: {effect}",
                      stacklevel=user_stacklevel())

    def _warn_glows_giving_none(self, constant: np.ndarray, sampled, glows: np.ndarray, materials: np.ndarray):
        """Warns, naming them, where the stage's only light sources, its glowing materials (``glows``, per device
        material, those named; ``materials`` per triangle), give no light where their geometry reads them: no
        triangle of a material of constant glow (``constant``, not cut out) and no row of ``sampled`` (the textured
        ones' reads, less those cut out) above 0. They keep the default lights away, as lights that give none do:
        the image is dark, said as for those."""
        if used_anywhere(constant, materials) or (sampled is not None and bool((sampled.values > 0.0).any())):
            return
        used = np.zeros(len(glows), bool)
        used[np.unique(materials)] = True
        paths = [self.scene.materials[m - 1].path or f"materials[{m - 1}]" for m in np.flatnonzero(glows & used)]
        warnings.warn(f"{self.scene.source or 'scene'}: no light: the stage's glowing materials glow nowhere on their "
                      "geometry (cut out everywhere, or their emission textures are black where it reads them): "
                      f"{', '.join(paths[:5])}{f' and {len(paths) - 5} more' if len(paths) > 5 else ''}; rendered "
                      "without the default lights, which are for stages without lights", stacklevel=user_stacklevel())

    def _upload_shading(self):
        scene, dev = self.scene, self.device
        mats, uvs, tri_materials, sided, emission, glow = shading_data(scene, dev)
        self._upload_cameras(self.cameras, self.batched)
        geometry_materials = scene.triangle_materials()
        # Per material: an emissive one (wrt.materials.can_emit, as the loader reads it), its texels' mean above 0 or
        # its fallback glowing where a UDIM tile has no file or a constant address mode leaves [0, 1]. By the mean
        # alone, a lamp glowing by its fallback whose triangles read only black tiles left the stage unlit (default
        # lights), where one glowing by another tile's image (as dark there) left it dark.
        glows = np.array([float(np.max(e)) > 0.0 for e in emission]) | np.array(
            [False] + [fallback_glows(m) for m in scene.materials])
        # A material cut out everywhere emits nothing (rays pass its holes and see no light; its light samples were
        # zero): its triangles and glowing shapes take no light picks, which they wasted. (It still counts as the
        # stage's light below: the stage's author lit it with that glow, and gets no default lights.)
        cut = np.array([False] + [wholly_cut_out(m) for m in scene.materials])
        lit = [np.zeros(3, np.float32) if c else e for c, e in zip(cut, emission)]
        # The triangles of textured emitters read on themselves: a UDIM tile without a file, a constant address
        # mode's default, ... glow where the texels' mean says none (wrt.sampled_emission). Kept with the scene: 500k
        # such triangles took 0.35 s of every Renderer.
        key = ("sampled_emission", str(dev))
        textured = np.array([False] + ["emissiveColor" in m.textures for m in scene.materials])
        # and those of a glow cut out by a texture: a triangle all in holes emits nothing (opaque_blocks)
        holed = glows & np.array([False] + ["opacity" in m.textures and m.opacity_threshold > 0.0
                                            for m in scene.materials])
        textured |= holed
        if key not in scene._cache:
            # Of the images as checked and made RGBA float32 (an (H, W, 3) one built in Python was read as RGBA rows:
            # its channels mixed, or a reshape error that stopped the render); not made where nothing reads them.
            images = scene_images(scene.textures) if textured.any() else []
            tiles = [None] + [tile_emission_estimates(m, images) if t else None for m, t in zip(scene.materials,
                                                                                             textured[1:])]
            maps, holes = block_maps(scene.materials, images, textured, holed)
            scene._cache[key] = sampled_emission(mats, uvs, geometry_materials, emission, textured, dev, tiles, maps,
                                                 holes)
        read = scene._cache[key]
        # Read for the cut-out ones too, which count as the stage's light where they glow, as a cut-out material of
        # constant glow does; the reads add a glow no material tells (any texture's fallback at a NaN st).
        emissive_used = used_anywhere(glows, geometry_materials) or (
            read is not None and bool((read.values > 0.0).any()))
        sampled = read if read is None or not cut.any() else read.without(cut, geometry_materials)
        # A stage with no light source at all gets the documented default lights, whose headlight (light 0) travels
        # along the viewing direction of each camera of a batch; not one whose author lit it with lights that gave
        # none (hidden, or skipped: Scene.dark_lights), as Hydra renderers add none to a stage that has lights.
        unlit = not (scene.lights or emissive_used)
        default = unlit and not scene.dark_lights
        # Said only where lights could have changed the image: ao and the quick looks read none.
        if unlit and scene.dark_lights and self.integrator in LIGHT_SAMPLING_INTEGRATORS:
            warnings.warn(f"{scene.source or 'scene'}: no light: the stage's lights give none (hidden, or skipped "
                          f"as the load warned): {', '.join(scene.dark_lights[:5])}"
                          f"{f' and {len(scene.dark_lights) - 5} more' if len(scene.dark_lights) > 5 else ''}; "
                          "rendered without the default lights, which are for stages without lights",
                          stacklevel=user_stacklevel())
        if not scene.lights and emissive_used and self.integrator in LIGHT_SAMPLING_INTEGRATORS:
            named = glows.copy()  # and those that glow by a fallback at a NaN st alone
            if read is not None:
                named[geometry_materials[read.ids[(read.values > 0.0).any(axis=1)]]] = True
            self._warn_glows_giving_none(glows & ~cut & ~textured, sampled, named, geometry_materials)
        self._lights = tuple(default_lights(self._forwards[0]) if default else scene.lights)
        # The shading kernels' variant for these lights (wrt.light_features): set with them, so it is never stale.
        table = build_lights(list(self.lights), scene, lit, dev, glow, sampled)
        self.device_lights, self._light_features = table.device_lights, table.features
        # Emission held times a power of two that keeps path estimates within float32 (wrt.radiance_scale), which
        # the image is divided by: 1 but for lights or glows past 2^64 or below 2^-64.
        self._radiance_scale = float(self.device_lights.radiance_scale)
        self.materials = scaled_materials(mats, self._radiance_scale, dev)
        self._warn_unsampled(table.unsampled)
        self._headlight = 0 if default else -1
        self._point_headlight()
        # The emitter slots and no-response triangles come from the host rows the lights were made of, and the
        # materials from the host's: read back from the device, each upload waited on up to seven copies (a sync each).
        if len(table.no_response):  # they take the last device material (wrt.materials.no_response_material)
            overridden = np.array(geometry_materials, np.int32)  # a copy: the cached array is the scene's own
            overridden[table.no_response] = len(scene.materials) + 1
            tri_materials = wp.array(overridden, dtype=wp.int32, device=dev)
        s = DeviceSurfaces()
        s.uvs, s.materials, s.double_sided = uvs, tri_materials, sided
        s.emitters = wp.array(table.emitter_slots, dtype=wp.int32, device=dev)
        partners = scene.triangle_partners()  # None unless a single-sided triangle has a coincident partner
        offsets, ranges = partners or (np.zeros(1, np.int32), np.zeros((1, 2), np.int32))
        s.num_partners = 0 if partners is None else len(offsets) - 1
        s.partner_offsets = wp.array(offsets, dtype=wp.int32, device=dev)
        s.partner_ranges = wp.array(ranges, dtype=wp.vec2i, device=dev)
        self.surfaces = s
        # Camera and bounce rays skip holes of cut-outs, camera rays back faces of single-sided meshes too
        # (hidden_hits.intersect_visible).
        cut_outs = np.array([False] + [m.opacity_threshold > 0.0 for m in scene.materials])  # per device material
        # Shadow rays see both sides, but pass through holes too (hidden_hits.occluded_through_holes).
        self.no_holes = not used_anywhere(cut_outs, geometry_materials)
        self.nothing_to_cull = bool(scene.triangle_double_sided().all()) and self.no_holes
        # Whitted lights each UsdLux light (but the dome) separately and all emissive triangles as one light.
        n_analytic = self.device_lights.num_analytic
        self._whitted_groups = [(k, 1) for k in range(n_analytic) if k != self.device_lights.dome]
        if self.device_lights.count > n_analytic:
            self._whitted_groups.append((n_analytic, self.device_lights.count - n_analytic))
        groups = np.array(self._whitted_groups or [(0, 0)], np.int32).reshape(-1, 2)
        self._whitted_group_array = wp.array(groups, dtype=wp.vec2i, device=dev)

    @one_call_at_a_time
    def set_cameras(self, cameras) -> None:
        """Renders from ``cameras`` (a list, tuple or generator; any length) from now on, e.g. new poses each
        simulation step; the BVH, materials and lights stay (a default headlight turns with each camera). The image
        keeps its size, unless the render settings were replaced since the last render: then it takes theirs. From
        then on :meth:`render` and :meth:`frame_image` return a :class:`BatchImage`, also for a list of one camera
        and for a renderer made with ``camera=``."""
        # The uploads would be recorded: every replay copied the poses given then (from an array freed since) over
        # those set later, and the frame was refused as drawn before the cameras last changed.
        self._outside_capture("set_cameras()", "call it outside the capture (a replay draws the cameras set last)")
        with self._scene_turn():  # first: it reads the scene (the cameras at its paths, its bounds)
            self._set_cameras(cameras)

    def _set_cameras(self, cameras) -> None:
        """:meth:`set_cameras`, in the scene's turn (:meth:`_scene_turn`)."""
        # Without render settings the size is the one made (a side not given took the first camera's aspect then);
        # with them, the size asked for, which each stage camera's data window crops again.
        asked = self._asked_size if self.scene.render_settings is not None else (self.width, self.height)
        cameras = given = camera_list(cameras)
        key = self._camera_sources_key(given)  # before they are read (_follow_cameras)
        views = resolve_views(self.scene, cameras, *asked)
        windows = [view_window(self.scene, c, *asked) for c in cameras]
        # The renderer's size, unless the render settings were replaced since it last drew: then the size they give
        # now (a new resolution or data window), as a new Renderer's; the old size was refused as a mix of camera
        # kinds under a data window.
        replaced = self._settings_view() != self._camera_key[0]
        size = views[0][1:] if replaced else (self.width, self.height)
        _check_one_size(views, *views[0][1:])  # a mix of cropped stage cameras and Camera objects
        if views[0][1:] != size:  # of one kind, but not the kind the renderer's size was made for
            raise ValueError(f"set_cameras: these cameras' images are {'x'.join(map(str, views[0][1:]))} but the "
                             f"renderer's are {'x'.join(map(str, size))} (the render settings' dataWindowNDC crops "
                             "stage cameras, not wrt.Camera objects): give cameras of the kind the Renderer was made "
                             "with, or make a new Renderer for these")
        cameras = [view[0] for view in views]
        n = len(cameras) * size[0] * size[1]
        if n > MAX_PIXELS:  # (camera_list refused none)
            raise ValueError(f"need 1 to {MAX_PIXELS // (size[0] * size[1])} cameras, got {len(cameras)}")
        resized = len(cameras) != len(self.cameras)
        self._upload_cameras_at(cameras, size, batched=True)  # a bad camera raises before any change
        self._windows = windows
        self._batched = True
        self._camera_args = given
        self._sides = (self.width, self.height)  # set_cameras keeps the size made
        self._camera_key = key
        self._note_views()
        if resized:
            # launch_frame's buffers are sized for the old count: it wrote past their end (a crash, or a wrong
            # frame_image) with more cameras and read past the camera array with fewer.
            self._frame = None
        self._drop_sums("set_cameras was called")
        self._warn_clipped_away()

    def _outside_capture(self, call: str, instead: str) -> None:
        """Raises RuntimeError, naming ``call`` and what to do ``instead``, inside a graph capture on the device."""
        if wp.get_device(self.device).is_capturing:
            raise RuntimeError(f"{call} cannot be recorded in a graph: {instead}")

    def _drop_sums(self, why: str) -> None:
        """Drops the progressive sums (of another view) and keeps ``why`` for the warning of a ``resume=True``:
        after a camera edit or set_cameras it said "the scene changed", or nothing at all."""
        if self._progressive is not None:
            self._sums_dropped = why
        self._progressive = None  # a drop with none left keeps the reason given when they were

    def _upload_cameras_at(self, cameras: list, size: tuple[int, int], batched: bool) -> None:
        """:meth:`_upload_cameras` for images of ``size``, the renderer's size from then on (its buffers made anew
        where it changed); nothing changes when a camera is refused."""
        old = (self.width, self.height)
        self._width, self._height = size
        try:
            self._upload_cameras(cameras, batched)
        except Exception:
            self._width, self._height = old
            raise
        if size != old:
            self._wavefront = self._frame = None  # sized for the old image

    def _upload_cameras(self, cameras: list, batched: bool) -> None:
        """Makes ``cameras`` the renderer's, their device structs and lenses uploaded; raises (naming the camera by
        its index where ``batched``) before any change when one of them is bad."""
        structs = camera_structs(cameras, self.width, self.height, batched)
        cams = wp.array(structs, dtype=DeviceCamera, device=self.device)
        lens_list = [self._lens(c) for c in cameras]
        for k, cam in enumerate(cameras):
            # Named as camera_structs names it: by its label alone, "camera" for all made in Python, the first only
            # was warned of. (One alone, set_cameras([c]) each frame of an animation as Renderer(camera=c), keeps it.)
            name = camera_name(cam, k, len(cameras))
            warn_scene_too_far(self.scene, cam, self.width, self.height, self._said_once, name)
            warn_shapes_too_far(self.scene, cam, self.width, self.height, self._said_once, name)
        lenses = wp.array(lens_list, dtype=wp.vec2, device=self.device)
        if getattr(self, "_cams", None) is not None and len(self._cams) == len(cams):
            # Copied into the arrays the kernels were given, not swapped for new ones: a frame recorded as a CUDA
            # graph (launch_frame) replays with the arrays it was recorded with, and kept drawing the old poses.
            self._cams.assign(cams)
            self._lenses.assign(lenses)
        else:
            self._cams, self._lenses = cams, lenses
        self._cameras, self._camera = tuple(cameras), cameras[0]
        self._camera_uploads = next_number(self._camera_uploads)
        self._camera_upload_number.fill_(self._camera_uploads)
        self._thin_lens = any(radius > 0.0 for radius, _ in lens_list)  # some camera has depth of field
        # Read now, as the pose and lens are: a camera changed after this is uploaded again at the next render
        # (_follow_cameras), and a scale made NaN after its check would have darkened the image silently.
        self._exposures = [float(c.exposure_scale) for c in cameras]
        self._forwards = np.array([np.array(s.forward) for s in structs], np.float64)  # (V, 3) viewing directions
        if hasattr(self, "device_lights"):  # set_cameras; the first call comes before the lights are built
            self._point_headlight()

    def _point_headlight(self) -> None:
        """Points the default headlight (if the scene has one) along every camera's viewing direction."""
        set_headlight_directions(self.device_lights, self._headlight, self._forwards, self.device)

    def _lens(self, cam: Camera) -> tuple[float, float]:
        """Thin-lens radius and focus distance (scene units); radius 0 for a pinhole.

        The aperture diameter is ``focalLength / fStop``, the focal length in USD's tenths of a scene unit (the film
        unit, ``APERTURE_UNIT``), so a stage scaled as a whole keeps its depth of field whatever its
        ``metersPerUnit``.
        """
        if cam.projection != "perspective" or not cam.f_stop > 0.0 or not cam.focus_distance > 0.0:
            return 0.0, 1.0
        with np.errstate(over="ignore", divide="ignore"):
            radius = np.float64(cam.focal_length) * APERTURE_UNIT / (2.0 * np.float64(cam.f_stop))
            # A lens sample moves the ray's origin up to `side` off the eye, and turns it by side / focus_distance
            # (camera-space depth): past float32's range both made the rays NaN and the image background, unsaid.
            side = radius * max(np.linalg.norm(cam.to_world[:3, 0]), np.linalg.norm(cam.to_world[:3, 1]))
            reach = max(side + np.linalg.norm(cam.to_world[:3, 3]), side / np.float64(cam.focus_distance))
        if not reach < FLOAT32_MAX / 8:  # room for the sums and the length the kernel takes
            raise ValueError(f"{cam.label()}: its thin lens reaches {reach:.3g} scene units (radius {radius:.3g}), "
                             f"past float32's range (its rays would be NaN): focal_length={cam.focal_length:.6g}, "
                             f"f_stop={cam.f_stop:.6g}, focus_distance={cam.focus_distance:.6g}; an f_stop of 0 is a "
                             "pinhole")
        return float(radius), float(cam.focus_distance)

    @one_call_at_a_time
    def render(
        self, spp: int = 1, seed: int = 0, *, batch: int | None = None, progress: bool = False, resume: bool = False
    ) -> Image:
        """Renders ``spp`` samples per pixel and returns the :class:`Image` (a :class:`BatchImage` for a renderer made
        with ``cameras=``, or once :meth:`set_cameras` was called); AOVs come from a ray through each
        pixel's centre, as the colour of an image of one sample does (several spread all over the pixel).

        Args:
            spp: samples per pixel (the quick-look integrators ``normals``, ``depth`` and ``albedo`` use one).
            seed: seed of every random decision; the same seed gives the same image on the same device.
            batch: samples per pixel per launch; default: as many as fit in :data:`MAX_PATHS_PER_LAUNCH` paths.
                The image does not depend on it.
            progress: show a progress bar (tqdm) over the samples.
            resume: progressive rendering: add ``spp`` samples to those of the previous call (same ``seed``) and
                return the mean of all of them, exactly the image one call with the total would give;
                :attr:`dropped_samples` and its warning count the samples left out of all of them, as that call would.
        """
        # It reads back between bounces: recorded, its image was of launches not yet run (garbage on the CPU).
        self._outside_capture("render()", "record launch_frame() instead and read frame_image() after a replay")
        if isinstance(spp, bool) or not isinstance(spp, (int, np.integer)) or spp < 1:
            raise ValueError(f"spp must be a positive integer, got {spp!r}")
        if batch is not None and (isinstance(batch, bool) or not isinstance(batch, (int, np.integer)) or batch < 1):
            raise ValueError(f"batch must be a positive integer, got {batch!r}")
        spp, seed = int(spp), check_seed(seed)
        # By their truth, resume="false" added these samples to the previous render's without a word.
        progress, resume = flag(progress, "progress"), flag(resume, "resume")
        self._follow()  # a rebuild drops the progressive sums, and so does a camera edit
        # The ids of the scene drawn, kept with the sums: image_so_far() after an edit expanded them by the new scene.
        rows = self._id_rows.copied()
        quick_look = self.integrator in QUICK_LOOKS
        state = self._progressive
        resuming = resume and state is not None and state["seed"] == seed and not quick_look
        if resume and not resuming and not quick_look and (state is not None or self._sums_dropped):
            # The image is of these samples alone: said, where a caller adding samples would take it for the sum; once
            # per cause (_warn_once), as a loop passing the frame number as the seed started over at every frame.
            why = (f"seed {seed} is not the previous render's ({state['seed']}); said once: a later render of another "
                   "seed starts over too" if state is not None else f"{self._sums_dropped} since the previous render")
            self._warn_once(("resume starts over", "seed" if state is not None else self._sums_dropped),
                            f"resume=True starts over from no samples: {why}")
        if quick_look and spp > 1:  # said as wrt render says --spp with a quick look: the image was of one sample
            sampled = [name for name in INTEGRATORS if name not in QUICK_LOOKS]
            self._warn_once(("quick look spp",), f"spp applies to integrator {', '.join(map(repr, sampled[:-1]))} and "
                            f"{sampled[-1]!r} only; {self.integrator!r} draws one sample per pixel, through its centre")
        if quick_look:
            spp = 1
        if (state["samples"] if resuming else 0) + spp > MAX_SPP:
            raise ValueError(f"spp must be at most 2^31 - 1 samples per pixel in all, got {spp}"
                             + (f" after {state['samples']}" if resuming else ""))
        # An image of several samples spreads sample 0 over the pixel too (_start_and_trace); one of a single sample
        # takes it through the pixel centre. Adding to that one, its sample is drawn again, spread, so that the image
        # stays that of one render of all the samples.
        spread = (state["samples"] if resuming else 0) + spp > 1
        if resuming and state["spread"] != spread:
            spp += state["samples"]
            resuming = False
        n_pixels = self.width * self.height * len(self.cameras)
        batch = samples_per_launch(n_pixels, spp, batch)
        n = n_pixels * batch
        if self._wavefront is None or self._wavefront.n < n:
            self._check_launch(n_pixels, batch)
            self._wavefront = _Wavefront(n, self.device, self.nothing_to_cull, self.no_holes)
        dev = self.device
        if resuming:
            image, dropped, aovs, done = state["sum"], state["dropped"], state["aovs"], state["samples"]
        else:
            image = wp.zeros(n_pixels, dtype=wp.vec3, device=dev)
            dropped = wp.zeros(1, dtype=wp.int32, device=dev)
            aovs = _AovBuffers(n_pixels, dev)
            done = 0

        from tqdm import tqdm

        bar = tqdm(total=spp, unit="spp", desc=f"wrt {self.integrator}", disable=not progress, leave=False)
        total = done + spp
        first = done
        try:
            with self._timer("render"), wp.ScopedDevice(dev):
                while first < total:
                    count = min(batch, total - first)
                    w = self._wavefront.view(n_pixels * count)
                    self._start_and_trace(w, first, seed, aovs, spread)
                    wp.launch(accumulate_samples_kernel, n_pixels, inputs=[w.radiance, n_pixels, count],
                              outputs=[image, dropped])
                    aovs.add_covered()
                    first += count
                    bar.update(count)
        finally:
            # The sums hold exactly the launches finished so far, also when interrupted (Ctrl-C): a later
            # resume=True continues from them. Recorded only at the end, a resumed render interrupted midway left
            # its extra samples in the sums under the old count, and the next resume came out too bright.
            bar.close()
            self._progressive = {"seed": seed, "sum": image, "dropped": dropped, "aovs": aovs, "samples": first,
                                 "spread": spread, "rows": rows}
        self.dropped_samples = int(dropped.numpy()[0])
        self._warn_dropped(total, resumed=done > 0)
        return self._mean_image(image, total, aovs, rows)

    def _check_launch(self, n_pixels: int, batch: int) -> None:
        """Refuses launches of ``batch`` samples of ``n_pixels`` pixels that Warp cannot index or the device cannot
        hold, naming the request, before anything is allocated: Warp failed with its own words (an array shape past
        2^31, "Failed to allocate N bytes") and a CPU render past the host's memory could be killed by the system."""
        views = f" x {len(self.cameras)} cameras" if len(self.cameras) > 1 else ""
        what = f"rendering {self.width}x{self.height}{views} at {batch} samples per launch"
        if n_pixels * batch > MAX_LAUNCH_PATHS:
            raise ValueError(f"{what} is {n_pixels * batch} paths; a launch takes at most 2^31 - 1: lower batch")
        needed = render_bytes(n_pixels, n_pixels * batch)
        per = lights_per_batch(len(self._whitted_groups), n_pixels * batch) if self.integrator == "whitted" else 1
        if per > 1:  # whitted's shadow rays of several lights per path (_Wavefront.shadow_rays)
            needed += per * n_pixels * batch * ShadowRays.BYTES_PER_RAY
        check_memory(needed, self.device, what=what)

    @property
    def samples_so_far(self) -> int:
        """Samples per pixel in the progressive sums: those of the last :meth:`render`, also an interrupted one."""
        return self._progressive["samples"] if self._progressive else 0

    @one_call_at_a_time
    def image_so_far(self):
        """The mean of the samples the last :meth:`render` finished, also when it was interrupted (Ctrl-C), so that
        a long render stopped early still gives its picture; None before the first finished launch."""
        self._outside_capture("image_so_far()", "call it after the capture")  # its kernels would only be recorded
        samples = self.samples_so_far
        if samples == 0:
            return None
        state = self._progressive
        return self._mean_image(state["sum"], samples, state["aovs"], state["rows"])

    @one_call_at_a_time
    def launch_frame(self, seed: int = 0) -> None:
        """Launches one sample per pixel with no host synchronisation, so that the launches can be recorded in a
        CUDA graph (``wp.ScopedCapture``) and replayed: every bounce up to ``max_depth`` is launched (finished paths
        do no work). In a scene with cut-outs, camera and bounce rays run up to :data:`wrt.shade.MAX_CULL_PASSES`
        passes past holes (which use up no bounce) and shadow rays up to :data:`wrt.shade.MAX_SHADOW_HOLE_PASSES`,
        so the frame passes as many holes in a row as :meth:`render`; without cut-outs back-face culling runs up to
        :data:`CAPTURE_CULL_PASSES` passes. Inside a CUDA graph capture the passes are a loop of the graph that
        stops once no ray needs another (:func:`wrt.hidden_hits.repeat_passes`); outside one, all of them run. Buffers
        are allocated on the first call, so make one call before capturing. :meth:`frame_image` reads the result. A
        recorded graph replays the scene's device arrays as they were: after an edit of the scene, call once outside
        a capture (it builds them again) and record again (each recorded graph keeps the arrays it reads for as long as
        it lives, and :meth:`frame_image` refuses an old graph's frame); :meth:`set_cameras` with the same
        camera count is followed, and so is a camera edited since once a call outside the capture has uploaded it
        again (until then :meth:`frame_image` refuses the frame, naming the camera and the fields edited), but for
        depth of field switched on since: then record again (:meth:`frame_image` refuses the old recording's
        frame). Only this call can be recorded: :meth:`render`, :meth:`frame_image`, :meth:`image_so_far` and
        :meth:`set_cameras` raise inside a capture."""
        self._follow()
        n_pixels = self.width * self.height * len(self.cameras)
        if self._frame is None:
            self._check_launch(n_pixels, 1)
            self._frames_made = next_number(self._frames_made)
            self._frame = (_Wavefront(n_pixels, self.device, self.nothing_to_cull, self.no_holes),
                           wp.zeros(n_pixels, dtype=wp.vec3, device=self.device),
                           wp.zeros(1, dtype=wp.int32, device=self.device), _AovBuffers(n_pixels, self.device),
                           wp.zeros(1, dtype=wp.int32, device=self.device),
                           wp.zeros(1, dtype=wp.int32, device=self.device))
        w, image, dropped, aovs, lens_pass, cameras_drawn = self._frame
        if wp.get_device(self.device).is_capturing:
            # A graph holds raw pointers: a rebuild after a scene edit dropped the BVH, device scene and frame buffers
            # it was recorded with, and its replay launched kernels on freed memory. They are kept (every attribute as
            # it is now, but render's own buffers) by the graph itself, for as long as it lives: kept by the renderer
            # until the next recording only, a graph older than that replayed on freed memory.
            recorded = held_values(value for name, value in vars(self).items()
                                   if name not in ("_recorded", "_wavefront", "_progressive"))
            graph = capturing_graph(self.device)
            if graph is not None:
                graph.__dict__.setdefault("wrt_recorded", []).append(recorded)
            self._recorded = recorded if graph is None else ()  # where Warp's graph cannot be found: the last one's
        aovs.done = False
        self._sync_free = True
        try:
            with wp.ScopedDevice(self.device):
                image.zero_()
                dropped.zero_()  # the frame's own count (frame_image reads it), recorded too: replays do not add up
                # Whether sample 0 samples the lens is fixed when the frame is recorded as a CUDA graph; the fill is
                # recorded with it, so frame_image can tell a replay of a frame recorded without the lens pass.
                lens_pass.fill_(self._lens_first())
                self._frame_number.fill_(self._frames_made)  # recorded too: a replay of an older frame writes its own
                wp.copy(cameras_drawn, self._camera_upload_number)  # the upload a replay reads, as the replay runs
                aovs.covered.zero_()
                self._start_and_trace(w, 0, check_seed(seed), aovs)
                wp.launch(accumulate_samples_kernel, n_pixels, inputs=[w.radiance, n_pixels, 1],
                          outputs=[image, dropped])
                aovs.add_covered()
        finally:
            self._sync_free = False

    def _check_frame_scene(self) -> None:
        """:meth:`frame_image`'s checks that the frame is of the scene and cameras as they are now."""
        if self._frame is None:  # also after set_cameras changed the camera count, or the scene was rebuilt
            raise RuntimeError("frame_image() needs a launch_frame() first (since the last change of the camera "
                               "count, of the image size or of the scene)")
        if self._scene_changed() or int(self._frame_number.numpy()[0]) != self._frames_made:
            # A graph recorded before the buffers were made anew replayed into the old ones (kept: launch_frame); one
            # replayed after a scene edit with no launch_frame outside a capture since drew the old scene.
            raise RuntimeError("the frame was recorded (or drawn) before the scene changed (or the image size or "
                               "camera count): it shows the old scene; call launch_frame() once outside the capture, "
                               "then record the frame again")
        changed = self._camera_changes()
        if changed:
            # The graph reads the cameras as last uploaded: a camera moved (or given a new fov, lens or film) since
            # replayed the old view without a word.
            raise RuntimeError(f"{changed} changed since the cameras were uploaded: the frame (or its graph's replay) "
                               "shows the old view; call launch_frame() once outside the capture (it uploads them), "
                               "then replay")

    @one_call_at_a_time
    def frame_image(self):
        """The :class:`Image` (or :class:`BatchImage`) of the last :meth:`launch_frame` (or of its graph's replay).

        Raises:
            RuntimeError: no frame was launched since the camera count, the image size or the scene changed, the
                frame is a replay of a graph recorded before such a change, or the frame was drawn (or its graph
                recorded) before a camera got depth of field: record it again. Also where a camera was edited since
                the cameras were uploaded (the error names it and its fields: a graph replays the uploaded view),
                and where the frame was drawn before the last upload (:meth:`set_cameras`, or an edited camera that
                :meth:`render` uploaded) with no replay since."""
        # Its coverage (and a batch's mean) kernels would only be recorded: their arrays held garbage.
        self._outside_capture("frame_image()", "call it after the capture, after a replay")
        with self._scene_turn():  # first: the checks read the scene and its cameras
            self._check_frame_scene()
        _, image, dropped, aovs, lens_pass, cameras_drawn = self._frame
        if int(lens_pass.numpy()[0]) < self._lens_first():
            # A graph recorded for pinhole cameras replays sample 0 through the lens centre: a sharp image where the
            # camera uploaded since has depth of field, drawn without a word.
            raise RuntimeError("the frame was drawn (or recorded in a graph) before a camera got depth of field "
                               "(f_stop and focus_distance): call launch_frame() once outside the capture, then "
                               "record the frame again")
        if int(cameras_drawn.numpy()[0]) != self._camera_uploads:  # new poses uploaded after the frame was drawn
            raise RuntimeError("the frame was drawn (or its graph replayed) before the cameras last changed "
                               "(set_cameras, or a camera edit that render() uploaded): it shows the old view; replay "
                               "the graph or call launch_frame() again")
        # The frame's count: dropped_samples kept the last render()'s, of other samples, without a word.
        self.dropped_samples = int(dropped.numpy()[0])
        self._warn_dropped(1)
        # The scene is checked unchanged above, and one camera's ids are expanded at once (finish_image), so they
        # read the instances' prototype ids of the build as they are: copied, 20 MB per frame at 5M instances. A
        # BatchImage expands its views later, after edits maybe, so it keeps a copy.
        return self._mean_image(image, 1, aovs, self._id_rows.copied() if self.batched else self._id_rows)

    def _start_paths(self, w: _Wavefront, first_sample: int, seed: int, first: int) -> None:
        wp.launch(
            start_paths_kernel,
            w.n,
            inputs=[self._cams, self._lenses, self.width, self.height, first_sample, seed, first],
            outputs=[*w.rays, w.rng, w.throughput, w.radiance, w.alive, w.pdf_prev, w.prev_normal, w.views],
        )

    def _lens_first(self) -> int:
        """1 where the colour's sample 0 samples the lens (some camera has depth of field; not the quick looks)."""
        return int(self._thin_lens and self.integrator not in QUICK_LOOKS)

    def _start_and_trace(self, w: _Wavefront, first_sample: int, seed: int, aovs, spread: bool = False):
        # Colour samples of an image of several (``spread``) are all spread over the pixel and the lens, and behind a
        # thin lens every colour sample samples the lens: sample 0 through the centres, the AOVs' ray, was a point
        # sample of weight 1 / spp and blended a sharp pinhole image into the blur (shade.camera_sample). The AOV
        # rays are then traced apart, once. The quick looks' image is their AOVs: their one sample stays the AOV ray.
        first = FIRST_ON_LENS if self._lens_first() else FIRST_AT_CENTRE
        if spread and self.integrator not in QUICK_LOOKS:
            first = FIRST_SPREAD
        if first != FIRST_AT_CENTRE and aovs is not None and not aovs.done:
            v = w.view(aovs.n)
            self._start_paths(v, first_sample, seed, FIRST_AT_CENTRE)
            self._intersect(v, aovs, camera_rays=True, count_covered=False)
        self._start_paths(w, first_sample, seed, first)
        if self.integrator == "path":
            self._trace_paths(w, aovs)
        elif self.integrator == "whitted":
            self._trace_whitted(w, aovs)
        else:
            self._intersect(w, aovs)
            if self.integrator == "ao":
                self._trace_ao(w)
            else:
                w.radiance.zero_()

    def _intersect(self, w: _Wavefront, aovs, camera_rays: bool = True, count_covered: bool = True):
        """Closest hits of the current rays past the holes of cut-outs (for camera rays: past culled back faces too);
        of camera rays, the samples that hit are counted for the coverage AOV (added by
        :meth:`_AovBuffers.add_covered`; not for the AOV rays traced apart, ``count_covered`` False), and the first
        time, the AOVs are written (of the AOV rays: sample 0 only where it goes through the pixel and lens centres)."""
        passes = None
        if self._sync_free:
            passes = CAPTURE_CULL_PASSES if self.no_holes else MAX_CULL_PASSES
        intersect_visible(self.accel, self.surfaces, self.materials, self.device_scene, w.rays, w.hits, w.scratch,
                          passes, camera_rays=camera_rays)  # the cost AOV counts camera rays only
        if aovs is not None and not aovs.done:
            n = aovs.n
            h = w.hits
            wp.launch(
                primary_aovs_kernel,
                n,
                inputs=[self.device_scene, self.surfaces, self.materials, self._cams, self.width * self.height]
                + [w.origins[:n], w.directions[:n], h.t[:n], h.u[:n], h.v[:n], h.prim[:n], h.instance[:n], h.cost[:n]],
                outputs=aovs.outputs,
            )
            aovs.done = True
        if aovs is not None and camera_rays and count_covered:
            wp.launch(count_covered_kernel, aovs.n, inputs=[w.hits.prim, aovs.n, w.n // aovs.n],
                      outputs=[aovs.launch_covered])

    def _occluded(self, w: _Wavefront, to_lights: bool = True, shadows: ShadowRays | None = None):
        """``blocked`` of the shadow rays (``shadows``, or ``w``'s own), which pass through the holes of cut-outs (in
        :meth:`launch_frame` without reading back: :func:`wrt.hidden_hits.repeat_passes`) and, when they go
        ``to_lights`` (their ``lights``), through the geometry that casts no shadow of their light, and not blocked
        by the emissive triangle each is aimed at."""
        shadows = shadows or w.shadow_rays()
        passes = MAX_SHADOW_HOLE_PASSES if self._sync_free else None
        lights = self.device_lights if to_lights else None
        occluded_through_holes(self.accel, self.surfaces, self.materials, shadows.rays, shadows.blocked,
                               shadows.scratch, passes, lights, shadows.lights, self.device_scene,
                               shadows.any_hit_t_maxs if to_lights else None)

    def _occlude_and_add(self, w: _Wavefront):
        self._occluded(w)
        launch_per_path(path_kernels(self._light_features).add_unoccluded, w.n,
                        [self.device_lights, w.nee, w.shadow_t_maxs, w.blocked, w.shadow_lights], [w.radiance],
                        self.device)

    def _any_alive(self, w: _Wavefront) -> bool:
        if self._sync_free:  # launch every bounce: finished paths do no work
            return True
        w.counter.zero_()
        wp.launch(count_alive_kernel, w.n, inputs=[w.alive], outputs=[w.counter])
        return int(w.counter.numpy()[0]) > 0

    def _trace_paths(self, w: _Wavefront, aovs):
        ds, surf, mats, lights = self.device_scene, self.surfaces, self.materials, self.device_lights
        for bounce in range(self.max_depth + 1):
            self._intersect(w, aovs, camera_rays=bounce == 0)
            h = w.hits
            launch_per_path(
                path_kernels(self._light_features).shade,
                w.n,
                [ds, surf, mats, lights, bounce, self.max_depth, RR_DEPTH, h.t, h.u, h.v, h.prim, h.instance, w.views],
                [*w.rays, w.rng, w.throughput, w.radiance, w.alive, w.pdf_prev, w.prev_normal, w.diffuse_share]
                + [w.link_groups, w.shadow_origins, w.shadow_dirs, w.shadow_t_maxs, w.shadow_lights]
                + [w.scratch.t_maxs, w.nee],  # the shadow rays' any-hit ends (ShadowRays.any_hit_t_maxs)
                self.device,
            )
            self._occlude_and_add(w)
            if not self._any_alive(w):
                break

    def _trace_whitted(self, w: _Wavefront, aovs):
        ds, surf, mats, lights = self.device_scene, self.surfaces, self.materials, self.device_lights
        for bounce in range(self.max_depth + 1):
            self._intersect(w, aovs, camera_rays=bounce == 0)
            h = w.hits
            hit = [h.t, h.u, h.v, h.prim, h.instance]
            launch_per_path(
                whitted_kernels(self._light_features).shade,
                w.n,
                [ds, surf, mats, lights, bounce, *hit, w.origins, w.directions, w.t_mins, w.t_maxs, w.throughput,
                 w.link_groups],
                [w.radiance, w.alive, w.rng],
                self.device,
            )
            self._light_whitted(w, hit)
            launch_per_path(
                whitted_kernels(self._light_features).continue_paths,
                w.n,
                [ds, surf, mats, lights, bounce, self.max_depth, *hit],
                [*w.rays, w.rng, w.throughput, w.alive, w.link_groups],
                self.device,
            )
            if not self._any_alive(w):
                break

    def _light_whitted(self, w: _Wavefront, hit: list):
        """Direct light at each hit from every light group (:attr:`_whitted_groups`): as many groups per launch as
        :func:`wrt.integrators.whitted.lights_per_batch` allows, their shadow rays traced together; the image is
        the one a launch per group gave."""
        groups = len(self._whitted_groups)
        per = lights_per_batch(groups, w.n)
        shadows = w.shadow_rays(per) if groups else None
        threads = resolve_threads(None, self.device)
        common = [self.device_scene, self.surfaces, self.materials, self.device_lights, self._whitted_group_array]
        candidates = emitter_resampling.EMITTER_CANDIDATES  # read at each render, so a test can compare with 1
        whitted_lights_kernel = whitted_kernels(self._light_features).lights
        add_unoccluded_lights_kernel = whitted_kernels(self._light_features).add_unoccluded
        for start in range(0, groups, per):
            count = min(per, groups - start)
            batch = shadows.head(count * w.n)

            def light(a: int, b: int, start=start, count=count, batch=batch):
                wp.launch(whitted_lights_kernel, b - a, device=self.device,
                          inputs=[*common, start, count, candidates, a, w.origins, w.directions, *hit, w.throughput,
                                  w.alive, w.views],
                          outputs=[w.rng, batch.origins, batch.dirs, batch.t_maxs, batch.lights,
                                   batch.any_hit_t_maxs, batch.contribution])

            def add(a: int, b: int, count=count, batch=batch):
                wp.launch(add_unoccluded_lights_kernel, b - a, device=self.device,
                          inputs=[self.device_lights, count, a, batch.contribution, batch.t_maxs, batch.blocked,
                                  batch.lights], outputs=[w.radiance])

            run_in_chunks(light, w.n, threads, [whitted_lights_kernel])  # on the CPU, pieces on a thread pool
            self._occluded(w, shadows=batch)
            run_in_chunks(add, w.n, threads, [add_unoccluded_lights_kernel])

    def _trace_ao(self, w: _Wavefront):
        h = w.hits
        launch_per_path(
            shade_ao_kernel,
            w.n,
            [self.device_scene, self.surfaces, self.ao_radius, w.origins, w.directions, h.t, h.u, h.v, h.prim,
             h.instance, w.rng],
            [w.shadow_origins, w.shadow_dirs, w.shadow_t_maxs],
            self.device,
        )
        self._occluded(w, to_lights=False)
        wp.launch(ao_value_kernel, w.n, inputs=[w.shadow_t_maxs, w.blocked], outputs=[w.radiance])

    def _exposure_scales(self) -> list[float]:
        """Each camera's factor on its mean radiance: its ``exposure_scale`` for the radiance integrators; the
        others' images are not radiance (ambient occlusion, quick looks)."""
        radiance = self.integrator in ("path", "whitted")
        if not radiance:
            return [1.0] * len(self._exposures)
        return self._exposures if self._radiance_scale == 1.0 else [e / self._radiance_scale for e in self._exposures]

    def _warn_dropped(self, spp: int, resumed: bool = False) -> None:
        """Warns of the samples left out of the image the last render (or frame) returned (:attr:`dropped_samples`),
        of the ``spp`` per pixel it adds up (``resumed``: over several renders), as they darken the pixels they fell
        in. A render with ``resume=True`` counts, and names, every sample of its image, as one render of them all
        would, so that the warnings of several resumes do not add up to more than were dropped. Said once
        (:meth:`_warn_once`), and once more for the first resumed image, whose count covers earlier renders: the
        count in the words changes from frame to frame, so a loop of 1000 frames gave 1000 lines."""
        if self.dropped_samples:
            over = f"of the image's {spp} sample(s) per pixel" + (", resumed renders included" if resumed else "")
            self._warn_once(("dropped samples", resumed), f"{self.scene.source or 'scene'}: {self.dropped_samples} "
                            "sample(s) were not finite, or passed float32's range in their pixel's sum, and were left "
                            f"out (Renderer.dropped_samples, {over}): the pixels they fell in are darker than they "
                            "should be; said once: Renderer.dropped_samples counts those of each later image")

    def _warn_clamped(self, pixels: int) -> None:
        """Warns of ``pixels`` whose mean radiance times the camera's exposure passed float32's range (its largest
        stands for it: inf reached the image, and NaN its tone mapping); once (:meth:`_warn_once`), as every frame
        of a loop gave it again."""
        if pixels:
            self._warn_once(("clamped pixels",),
                            f"{self.scene.source or 'scene'}: {pixels} pixel(s) of radiance times the camera's "
                            f"exposure past float32's range were clamped to its largest ({FLOAT32_MAX:.4g}): lower the "
                            "exposure or the lights; said once, not for each later image")

    def _warn_once(self, key: tuple, message: str) -> None:
        """Warns ``message`` unless a warning of ``key`` was said (:attr:`_said_once`): an image's warnings name its
        own counts, so Python's filter, which shows a message once, let a loop of frames repeat them at every frame."""
        if key in self._said_once:
            return
        warn_keyed(message, key)
        self._said_once.add(key)  # after: a warning that a filter makes an error raises again at the next image

    def _mean_image(self, image_sum: wp.array, samples: int, aovs: _AovBuffers, rows: IdRows):
        """The :class:`Image` (one camera) or :class:`BatchImage` of the sums of ``samples`` samples per pixel, prim
        ids expanded by ``rows`` (:meth:`Scene.id_rows` of the scene drawn). Either holds its own AOV arrays, not
        ``aovs``'s buffers, which later launches write again (:meth:`launch_frame`'s) and a ``resume=True`` render
        and :meth:`image_so_far` read again."""
        if self.batched:
            return self._batch_image(image_sum, samples, aovs, rows)
        return self._image(image_sum, samples, aovs, rows)

    def _image(self, image_sum: wp.array, samples: int, aovs: _AovBuffers, rows: IdRows) -> Image:
        rgb, clamped = mean_radiance(image_sum.numpy(), samples, self._exposure_scales()[0])
        self._warn_clamped(clamped)
        host = aovs.numpy(self.height, self.width, samples)
        if wp.get_device(self.device).is_cpu:
            # numpy() of a CPU array is a view of it: the next frame rewrote an image returned before (see _mean_image),
            # and an image's AOVs edited in place came back in the next resume=True render and image_so_far().
            host = {name: np.array(a) if name in aovs.arrays else a for name, a in host.items()}
        image = finish_image(rgb.reshape(self.height, self.width, 3), host, self.integrator, rows)
        image.pixel_aspect_ratio = self.camera.rendered_pixel_aspect(self.width, self.height)
        image.window = self._windows[0]
        return image

    def _batch_image(self, image_sum: wp.array, total: int, aovs: _AovBuffers, rows: IdRows):
        from .batch import BatchImage

        n, h, w = len(self.cameras), self.height, self.width
        arrays = aovs.device_arrays(total)
        # Copies of the buffers: the next frame rewrote a batch returned before, and a batch's AOVs edited in place
        # (through wp.to_torch) came back in the next resume=True render and image_so_far(), which read them again.
        arrays = {name: wp.clone(a) if name in aovs.arrays else a for name, a in arrays.items()}
        arrays = {name: a.reshape((n, h, w)) for name, a in arrays.items()}
        if self.integrator in ("normals", "depth", "albedo"):  # quick looks are made on the host, as for one camera
            host = {name: a.numpy() for name, a in arrays.items()}
            rgb = np.stack([finish_image(None, {k: v[i] for k, v in host.items()}, self.integrator, rows).rgb
                            for i in range(n)])
            rgb = wp.array(rgb, dtype=wp.vec3, device=self.device)
        elif not all(map(normal_float32, self._exposure_scales())):  # on the host, in float64 (mean_radiance)
            # A radiance scale past float32, or a camera exposure of 2^-150: the device's float32 factor was 0 or inf.
            sums = image_sum.numpy().reshape(n, h * w, 3)
            means = [mean_radiance(sums[k], total, f) for k, f in enumerate(self._exposure_scales())]
            self._warn_clamped(sum(clamped for _, clamped in means))
            rgb = wp.array(np.stack([m for m, _ in means]).reshape(n, h, w, 3), dtype=wp.vec3, device=self.device)
        else:
            rgb = wp.empty(n * h * w, dtype=wp.vec3, device=self.device)
            clamped = wp.zeros(1, dtype=wp.int32, device=self.device)
            scales = wp.array(self._exposure_scales(), dtype=float, device=self.device)
            wp.launch(mean_image_kernel, len(rgb), inputs=[image_sum, total, scales, h * w], outputs=[rgb, clamped],
                      device=self.device)
            self._warn_clamped(int(clamped.numpy()[0]))
            rgb = rgb.reshape((n, h, w))
        return BatchImage(rgb=rgb, aovs=arrays, scene=self.scene, integrator=self.integrator,
                          pixel_aspect_ratios=tuple(c.rendered_pixel_aspect(w, h) for c in self.cameras),
                          windows=tuple(self._windows), id_rows=rows)


def mean_radiance(sums: np.ndarray, samples: int, factor: float) -> tuple[np.ndarray, int]:
    """``sums / samples * factor`` (float32 ``sums``) and how many pixels passed float32's range (their values are its
    largest): in float32 where ``factor`` is a normal float32 (as the device's mean_image_kernel rounds it; a factor of
    1 changes no bit), else in float64 (an exposure of 2^-200 of a scene of 1e38, or a radiance scale past float32's
    range: the float32 factor was 0 or inf, and the image black or inf)."""
    with np.errstate(over="ignore"):
        if normal_float32(factor):
            rgb = sums / samples * np.float32(factor)
        else:
            rgb = (sums.astype(np.float64) / samples * factor).astype(np.float32)
    past = rgb > FLOAT32_MAX
    if not past.any():
        return rgb, 0
    return np.minimum(rgb, np.float32(FLOAT32_MAX)), int(past.reshape(-1, 3).any(axis=1).sum())


def normal_float32(factor: float) -> bool:
    """Whether float32 holds ``factor`` as it is: 0 or a normal float32 magnitude (a product by it rounds once)."""
    return factor == 0.0 or float(np.finfo(np.float32).tiny) <= abs(factor) <= FLOAT32_MAX


def finish_image(rgb, aovs: dict, integrator: str, rows: IdRows) -> Image:
    """The :class:`Image` of one camera from its mean radiance ``(H, W, 3)`` and its ``(H, W, ...)`` AOVs: prim ids
    as rows of ``Scene.triangles()`` (of the scene as it was drawn: ``rows``, :meth:`Scene.id_rows`), and the
    quick-look integrators' colours made from the AOVs."""
    out = dict(aovs)
    h, w = out["prim"].shape[:2]
    if rows.expands:  # report rows of Scene.triangles(), as Hits.prim does
        out["prim"] = rows.expand(out["prim"].reshape(-1), out["instance"].reshape(-1)).reshape(h, w)
    hit = out["prim"] >= 0
    if integrator == "normals":
        rgb = np.where(hit[..., None], 0.5 * (out["normal"] + 1.0), 0.0)
    elif integrator == "albedo":
        rgb = out["albedo"].copy()
    elif integrator == "depth":
        rgb = np.repeat(depth_grey(np.where(hit, out["depth"], np.inf))[..., None], 3, axis=-1)
    return Image(rgb=np.asarray(rgb, np.float32).reshape(h, w, 3), aovs=out, data=integrator in DATA_INTEGRATORS)


class _AovBuffers:
    """Device buffers of the AOVs of every pixel (of its ray through the pixel and lens centres), and the count of its
    samples whose camera ray hit something (``covered``, from which the ``coverage`` AOV is made)."""

    SPEC: ClassVar[dict] = {
        "depth": float,
        "z": float,
        "normal": wp.vec3,
        "geometric_normal": wp.vec3,
        "albedo": wp.vec3,
        "prim": wp.int32,
        "instance": wp.int32,
        "material": wp.int32,
        "cost": wp.vec2i,
    }

    def __init__(self, n: int, device):
        self.n = n
        self.done = False
        self.arrays = {name: wp.empty(n, dtype=dtype, device=device) for name, dtype in self.SPEC.items()}
        self.covered = wp.zeros(n, dtype=wp.int32, device=device)  # camera rays that hit, per pixel
        self.launch_covered = wp.zeros(n, dtype=wp.int32, device=device)  # those of the current launch

    def add_covered(self) -> None:
        """Adds the current launch's count to ``covered``, as its radiance is added to the image."""
        wp.launch(add_covered_kernel, self.n, inputs=[self.launch_covered], outputs=[self.covered],
                  device=self.covered.device)

    @property
    def outputs(self) -> list:
        return list(self.arrays.values())

    def device_arrays(self, samples: int) -> dict:
        """The AOVs on the device, ``coverage`` of ``samples`` samples per pixel included."""
        coverage = wp.empty(self.n, dtype=float, device=self.covered.device)
        wp.launch(coverage_kernel, self.n, inputs=[self.covered, samples], outputs=[coverage],
                  device=self.covered.device)
        return {**self.arrays, "coverage": coverage}

    def numpy(self, h: int, w: int, samples: int) -> dict:
        out = {}
        for name, arr in self.device_arrays(samples).items():
            a = arr.numpy()
            out[name] = a.reshape(h, w, *a.shape[1:])
        return out



def render(
    scene: Scene,
    *,
    camera=None,
    width: int | None = None,
    height: int | None = None,
    spp: int = 1,
    device=None,
    seed: int = 0,
    builder: str = "sah",
    accel: str = "wrt",
    integrator: str = "whitted",
    max_depth: int | None = None,
    ao_radius: float | None = None,
    batch: int | None = None,
    progress: bool = False,
) -> Image:
    """Renders ``scene`` and returns an :class:`Image`: linear radiance ``rgb`` plus AOVs (shown as a picture in
    Jupyter). A :class:`Renderer` keeps the BVH and buffers for repeated renders of one view.

    Each warning a Renderer says once (dropped samples, clamped pixels, a camera that sees nothing or is too far) is
    said once per scene over every call (:func:`wrt.far_views.shown_for_scene`): a stage by its file, as loaded at
    any time, until the file is edited; a scene made in Python by itself.

    Args:
        scene: a :class:`Scene` (``wrt.load_usd(path)`` or built in Python).
        camera: a :class:`Camera` (``Camera.look_at(eye, target)``), a camera prim path, or ``None``: the stage's
            render settings' camera, else its first camera, else one that frames the scene.
        width: image width in pixels; ``None``: the render settings' resolution, else 640 (else the camera's aspect
            of ``height``: :func:`default_image_size`).
        height: image height in pixels; ``None``: the render settings' resolution, else 480 (likewise).
        spp: samples per pixel (a positive integer).
        device: Warp device (``"cpu"``, ``"cuda:0"``); ``None``: Warp's default device.
        seed: seed of every random decision, 0 to 2^31 - 1; the same seed gives the same image on one device.
        builder: BVH builder (``"sah"``, ``"median"``, ``"lbvh"``, ...; see :func:`build_bvh`).
        accel: ``"wrt"`` (wrt's BVH) or ``"warp"`` (Warp's ``wp.Mesh``).
        integrator: ``"whitted"``, ``"path"`` (Monte Carlo path tracing), ``"ao"`` (ambient occlusion), or the
            quick looks ``"normals"``, ``"depth"``, ``"albedo"``.
        max_depth: bounces (``path``: surface interactions per path; ``whitted``: mirror and refraction bounces);
            ``None``: the integrator's default.
        ao_radius: occlusion distance of ``ao`` in scene units; ``None``: a tenth of the scene's diagonal.
        batch: samples per pixel per launch (the image does not depend on it); ``None``: as many as fit.
        progress: show a progress bar over the samples.

    Raises:
        ValueError: naming the argument that is out of range or unknown (a mistyped name gets a suggestion).
        TypeError: ``scene`` is not a :class:`Scene`, or ``camera`` none of the kinds above.
        SceneError: the scene cannot be drawn (a NaN vertex, an instance of a missing prototype), naming the prim.
    """
    check_scene(scene)  # before its warnings are looked up: a TypeError naming what was given
    with shown_across_renderers(shown_for_scene(scene)):  # each warning once over a loop of calls, not per call
        renderer = Renderer(scene, camera=camera, width=width, height=height, device=device, builder=builder,
                            accel=accel, integrator=integrator, max_depth=max_depth, ao_radius=ao_radius)
    return renderer.render(spp=spp, seed=seed, batch=batch, progress=progress)
