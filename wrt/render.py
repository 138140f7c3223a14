"""Rendering: camera rays -> trace -> shade -> :class:`Image`, as a reusable :class:`Renderer` and ``render()``."""

from __future__ import annotations

import math
import warnings

import numpy as np
import warp as wp

from .camera import Camera, frame_scene, generate_rays_kernel
from .image import Image
from .scene import Scene
from .shade import (
    HEADLIGHT_IRRADIANCE,
    accumulate_kernel,
    accumulate_light_kernel,
    prepare_shadow_rays_kernel,
    shade_base_kernel,
)
from .trace import HitBuffer, get_accelerator, resolve_device

MAX_PIXELS = 1 << 26  # 67 Mpixel: larger requests are refused before allocating


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
    if isinstance(camera, str):
        if camera in scene.cameras:
            return scene.cameras[camera]
        known = ", ".join(scene.cameras) or "none"
        raise ValueError(f"no camera at {camera!r}; cameras in the scene: {known}")
    raise TypeError(f"camera must be a wrt.Camera, a prim path string or None, not {type(camera).__name__}")


class Renderer:
    """Renders one scene from one camera at one resolution; reusable across calls and seeds.

    ``__init__`` resolves the camera, builds (or reuses) the accelerator and allocates every buffer; ``render()``
    only launches kernels. Wall times of each stage land in ``timers`` (seconds).

    Args:
        scene: the scene to render.
        camera: a :class:`Camera`, a camera prim path, or ``None`` (see :func:`resolve_camera`).
        width: image width in pixels.
        height: image height in pixels.
        device: Warp device; Warp's default device when ``None``.
        builder: BVH builder name.
        accel: ``"wrt"`` or ``"warp"``.
    """

    def __init__(self, scene: Scene, *, camera=None, width=640, height=480, device=None, builder="sah", accel="wrt"):
        for name, value in (("width", width), ("height", height)):
            if not isinstance(value, (int, np.integer)) or value <= 0:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if width * height > MAX_PIXELS:
            raise ValueError(f"{width}x{height} is {width * height} pixels; at most {MAX_PIXELS} are supported")
        self.scene = scene
        self.width, self.height = int(width), int(height)
        self.camera = resolve_camera(scene, camera)
        self.device = resolve_device(device)
        self.timers = {}
        if scene.stats()["rendered_triangles"] == 0:
            warnings.warn(f"{scene.source or 'scene'}: nothing to render (no triangles); the image is background only")
        with wp.ScopedTimer("build", print=False, dict=self.timers, synchronize=True):
            self.accel = get_accelerator(scene, accel, builder, self.device)
            self.device_scene = scene.to_device(self.device)
        self._allocate()

    def _allocate(self):
        n, dev = self.width * self.height, self.device
        self.origins = wp.empty(n, dtype=wp.vec3, device=dev)
        self.directions = wp.empty(n, dtype=wp.vec3, device=dev)
        self.t_mins = wp.empty(n, dtype=float, device=dev)
        self.t_maxs = wp.empty(n, dtype=float, device=dev)
        self.hits = HitBuffer(n, dev)
        self.shadow_origins = wp.empty(n, dtype=wp.vec3, device=dev)
        self.shadow_dirs = wp.empty(n, dtype=wp.vec3, device=dev)
        self.shadow_t_mins = wp.zeros(n, dtype=float, device=dev)
        self.shadow_t_maxs = wp.empty(n, dtype=float, device=dev)
        self.blocked = wp.empty(n, dtype=wp.int32, device=dev)
        self.radiance = wp.empty(n, dtype=wp.vec3, device=dev)
        self.image = wp.zeros(n, dtype=wp.vec3, device=dev)
        self.depth = wp.empty(n, dtype=float, device=dev)
        self.normal = wp.empty(n, dtype=wp.vec3, device=dev)
        self.albedo = wp.empty(n, dtype=wp.vec3, device=dev)
        self.prim = wp.empty(n, dtype=wp.int32, device=dev)
        lights = self.scene.lights
        dirs = [np.asarray(l.direction, np.float32) for l in lights] or [np.zeros(3, np.float32)]
        irradiance = [np.asarray(l.color, np.float32) for l in lights] or [np.full(3, HEADLIGHT_IRRADIANCE, np.float32)]
        self.light_dirs = wp.array(np.array(dirs), dtype=wp.vec3, device=dev)
        self.light_irradiance = wp.array(np.array(irradiance), dtype=wp.vec3, device=dev)

    def render(self, spp: int = 1, seed: int = 0) -> Image:
        """Renders ``spp`` samples per pixel and returns the :class:`Image`; AOVs come from the centre sample."""
        if not isinstance(spp, (int, np.integer)) or spp < 1:
            raise ValueError(f"spp must be a positive integer, got {spp!r}")
        n, dev = self.width * self.height, self.device
        cam = self.camera.to_struct(self.width, self.height)
        self.image.zero_()
        with wp.ScopedTimer("render", print=False, dict=self.timers, synchronize=True), wp.ScopedDevice(dev):
            for sample in range(int(spp)):
                rays = [self.origins, self.directions, self.t_mins, self.t_maxs]
                wp.launch(generate_rays_kernel, n, inputs=[cam, self.width, self.height, sample, int(seed)], outputs=rays)
                self.accel.intersect(*rays, self.hits)
                hit = [self.hits.t, self.hits.u, self.hits.v, self.hits.prim]
                aovs = [self.depth, self.normal, self.albedo]
                wp.launch(
                    shade_base_kernel,
                    n,
                    inputs=[self.device_scene, self.directions, *hit],
                    outputs=[self.radiance, *aovs] if sample == 0 else [self.radiance, *self._scratch_aovs()],
                )
                if sample == 0:
                    wp.copy(self.prim, self.hits.prim)
                for light in range(len(self.light_dirs)):
                    shadow = [self.shadow_origins, self.shadow_dirs, self.shadow_t_maxs]
                    wp.launch(
                        prepare_shadow_rays_kernel,
                        n,
                        inputs=[self.device_scene, self.origins, self.directions, *hit, self.light_dirs, light],
                        outputs=shadow,
                    )
                    self.accel.occluded(
                        self.shadow_origins, self.shadow_dirs, self.shadow_t_mins, self.shadow_t_maxs, self.blocked
                    )
                    wp.launch(
                        accumulate_light_kernel,
                        n,
                        inputs=[self.device_scene, self.directions, self.hits.u, self.hits.v, self.hits.prim]
                        + [self.shadow_t_maxs, self.blocked, self.light_dirs, self.light_irradiance, light],
                        outputs=[self.radiance],
                    )
                wp.launch(accumulate_kernel, n, inputs=[self.radiance, 1.0 / spp], outputs=[self.image])
        h, w = self.height, self.width
        return Image(
            rgb=self.image.numpy().reshape(h, w, 3),
            aovs={
                "depth": self.depth.numpy().reshape(h, w),
                "normal": self.normal.numpy().reshape(h, w, 3),
                "albedo": self.albedo.numpy().reshape(h, w, 3),
                "prim": self.prim.numpy().reshape(h, w),
            },
        )

    def _scratch_aovs(self):
        if not hasattr(self, "_scratch"):
            n, dev = self.width * self.height, self.device
            self._scratch = [
                wp.empty(n, dtype=float, device=dev),
                wp.empty(n, dtype=wp.vec3, device=dev),
                wp.empty(n, dtype=wp.vec3, device=dev),
            ]
        return self._scratch


def render(
    scene: Scene,
    *,
    camera=None,
    width: int = 640,
    height: int = 480,
    spp: int = 1,
    device=None,
    seed: int = 0,
    builder: str = "sah",
    accel: str = "wrt",
) -> Image:
    """Renders ``scene`` and returns an :class:`Image` (linear ``rgb`` plus ``depth``/``normal``/``albedo``/``prim``
    AOVs). See :class:`Renderer` for the arguments; ``seed`` fixes the pixel jitter when ``spp > 1``."""
    renderer = Renderer(scene, camera=camera, width=width, height=height, device=device, builder=builder, accel=accel)
    return renderer.render(spp=spp, seed=seed)
