"""Many cameras in one launch: ``render_batch`` for simulation and learning workloads (a camera per robot, per
environment, per sensor), where thousands of small images are rendered every step.

All cameras share one wavefront: path ``i`` belongs to camera ``(i % (n W H)) // (W H)``, so each pass over the
bounces is one kernel launch for every camera together, not a Python loop. The results stay in device memory as
``(n, H, W)`` Warp arrays, which ``wp.to_torch`` / ``wp.to_jax`` or DLPack (``torch.from_dlpack(batch.rgb)``) hand
over without a copy (vector dtypes become a trailing axis of 3 or 2).

View ``k`` of a batch is exactly the image a render of camera ``k`` alone gives (same seed): the random numbers of a
pixel depend on its position within its view, not on the view.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from .image import Aovs, Image
from .scene import IdRows, Scene


def host_copy(array: wp.array) -> np.ndarray:
    """``array`` on the host, a copy on every device: Warp's ``numpy()`` of a CPU array is a view of it, so an edit
    of what :meth:`BatchImage.numpy` or :meth:`BatchImage.image` returned rewrote the batch on the CPU alone."""
    host = array.numpy()
    return host.copy() if array.device.is_cpu else host


@dataclasses.dataclass
class BatchImage:
    """Images of ``n`` cameras rendered together, in device memory.

    Attributes:
        rgb: ``(n, H, W)`` ``wp.vec3`` array of linear radiance (``.numpy()`` gives ``(n, H, W, 3)`` float32).
        aovs: name -> ``(n, H, W)`` array of the AOVs of :class:`wrt.Image` (``vec3``/``vec2i`` dtypes add an axis).
            ``prim`` holds geometry ids (as :class:`wrt.trace.Hits` does before instances are expanded);
            :meth:`image` converts them to rows of ``Scene.triangles()`` as :class:`wrt.Image` has them.
        scene: the scene rendered.
        integrator: the integrator used.
        pixel_aspect_ratios: width / height of one pixel on each camera's film (:attr:`wrt.Image.pixel_aspect_ratio`;
            empty: square).
        windows: where each camera's image lies in its shot (:attr:`wrt.Image.window`: a stage camera under the
            render settings' ``dataWindowNDC``; ``None``: the whole shot; empty: every image is whole).
        id_rows: how :meth:`image` turns ``prim`` into rows of ``Scene.triangles()``: those of the scene as it was
            drawn (:meth:`wrt.Scene.id_rows`; ``None``: as ``scene`` is when the BatchImage is made), so that a view
            read after the scene was edited names the triangles drawn.
    """

    rgb: wp.array
    aovs: dict
    scene: Scene = dataclasses.field(repr=False)
    integrator: str = "whitted"
    pixel_aspect_ratios: tuple = ()
    windows: tuple = ()
    id_rows: IdRows | None = dataclasses.field(default=None, repr=False, compare=False)

    def __post_init__(self):
        self.aovs = Aovs(self.aovs)
        if self.id_rows is None:
            self.id_rows = self.scene.id_rows()

    def __len__(self) -> int:
        return self.rgb.shape[0]

    def numpy(self) -> tuple[np.ndarray, dict]:
        """Host copies: ``(rgb (n, H, W, 3), {name: (n, H, W, ...)})``."""
        return host_copy(self.rgb), {name: host_copy(a) for name, a in self.aovs.items()}

    def image(self, k: int) -> Image:
        """Camera ``k`` as a host :class:`wrt.Image` (the same object a single-camera render returns)."""
        from .render import DATA_INTEGRATORS, finish_image

        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):  # 1.0 failed in Warp, True meant camera 1
            raise TypeError(f"camera index must be an integer, got {k!r}")
        if not -len(self) <= k < len(self):
            raise IndexError(f"camera {k} out of range for a batch of {len(self)}")
        k = int(k) % len(self)  # Warp indexes wp.arrays with Python ints only
        rgb = host_copy(self.rgb[k])  # one camera's slice, not the whole batch
        aovs = {name: host_copy(a[k]) for name, a in self.aovs.items()}
        image = finish_image(rgb, aovs, "whitted", self.id_rows)  # rgb is already final, quick looks included
        shape = self.pixel_aspect_ratios[k] if self.pixel_aspect_ratios else 1.0
        window = self.windows[k] if self.windows else None
        return Image(rgb=rgb, aovs=image.aovs, pixel_aspect_ratio=shape, window=window,
                     data=self.integrator in DATA_INTEGRATORS)


def render_batch(
    scene: Scene,
    cameras,
    width: int = 64,
    height: int = 64,
    *,
    spp: int = 1,
    seed: int = 0,
    device=None,
    builder: str = "sah",
    accel: str = "wrt",
    integrator: str = "whitted",
    max_depth: int | None = None,
    ao_radius: float | None = None,
    batch: int | None = None,
) -> BatchImage:
    """Renders ``scene`` from every camera of ``cameras`` at ``width x height``, one launch per pass for all of them.

    Args:
        scene: the scene.
        cameras: a list of :class:`wrt.Camera` (each with its own pose and intrinsics) or camera prim paths; a
            tuple or a generator of them too.
        width: image width of every camera.
        height: image height of every camera.
        spp, seed, batch: as :meth:`wrt.Renderer.render`.
        device, builder, accel, integrator, max_depth, ao_radius: as :class:`wrt.Renderer`.

    Returns:
        A :class:`BatchImage`. To render the same cameras again (a new pose each step), keep a
        :class:`wrt.Renderer` made with ``cameras=`` instead: it builds the BVH once.
    """
    from .render import Renderer, not_a_camera_list

    if not_a_camera_list(cameras):  # (a TypeError here, as render_batch has always raised)
        raise TypeError(f"cameras must be a list of wrt.Camera or camera prim paths (for one camera: [camera]), "
                        f"got {type(cameras).__name__}")
    renderer = Renderer(
        scene,
        cameras=list(cameras),
        width=width,
        height=height,
        device=device,
        builder=builder,
        accel=accel,
        integrator=integrator,
        max_depth=max_depth,
        ao_radius=ao_radius,
    )
    return renderer.render(spp=spp, seed=seed, batch=batch)


__all__ = ["BatchImage", "render_batch"]
