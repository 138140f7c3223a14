"""Rays along which part of the scene lies past float32's largest ``t`` (3.4e38), found so that :func:`wrt.trace`
and :func:`wrt.occluded` can say so.

``t`` is in units of each ray's direction length, so a direction of length 1e-38 puts a triangle 1e4 away at
``t = 1e42``, and a unit direction from 3e38 puts one at -3e38 at ``t = 6e38``. Float32 holds no such ``t``: every
accelerator reports those hits as misses (``traverse.unit_ray``; ``wp.Mesh`` misses them too). Checking each ray's
entry into the scene's box costs one float64 slab test per ray, in one launch beside the trace's; the count is read
after the trace, whose hits are read anyway. On the CPU, where the rays' arrays are host memory, a float32 bound in
numpy clears ordinary batches first without a launch (10 rays: 26-47 us against 190-240 us with it, in a trace of
1.1-1.9 ms).
"""

from __future__ import annotations

import warnings

import numpy as np
import warp as wp

from .errors import user_stacklevel
from .floats import FLOAT32_MAX, largest_magnitude

wp.set_module_options({"enable_backward": False})  # nothing differentiates this kernel: no adjoint code to compile


@wp.kernel
def count_rays_past_float32_t_kernel(
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    lower: wp.vec3d,
    upper: wp.vec3d,
    reach: float,
    # outputs
    found: wp.array[wp.int32],
):
    """``found[0]``: the rays that meet the box ``lower, upper`` within their ``[t_min, t_max)`` beyond
    ``t = FLOAT32_MAX`` (or, with ``t_min = -inf``, before ``-FLOAT32_MAX``); ``found[1]``: the smallest of their rows
    (left as it was when there are none). Rays that cannot hit (NaN or infinite, zero directions, empty ranges) and
    those whose limits are finite float32s (they end them first) are not counted. In float64, where
    ``(bound - origin) / direction`` neither overflows nor rounds to 0 for float32 operands; most rays are passed over
    first: along a ray, ``|p - o|`` in the largest norm is ``|t|`` times the direction's largest component, so no point
    within ``reach`` (the box's largest coordinate) of the world origin has a ``|t|`` beyond ``(|o| + reach) / |d|``
    in that norm (halved on both sides, as ``|o| + reach`` may exceed float32's range)."""
    i = wp.tid()
    o = origins[i]
    d = directions[i]
    t_min = t_mins[i]
    t_max = t_maxs[i]
    if (t_max <= FLOAT32_MAX and t_min >= -FLOAT32_MAX) or not (t_max > t_min and wp.isfinite(o) and wp.isfinite(d)):
        return
    # |t| <= FLOAT32_MAX / 2 (the 2: past any rounding); the left side overflows only where |t| < FLOAT32_MAX / 2
    if largest_magnitude(d) * (float(FLOAT32_MAX) * 0.25) >= largest_magnitude(o) * 0.5 + reach * 0.5:
        return
    near = wp.float64(t_min)
    far = wp.float64(t_max)  # a finite t_max with t_min = -inf: the box beyond it is out of reach
    moves = bool(False)
    for k in range(3):
        dk = wp.float64(d[k])
        ok = wp.float64(o[k])
        if dk == wp.float64(0.0):
            if ok < lower[k] or ok > upper[k]:
                return  # beside the box, and never nearer
        else:
            moves = True
            a = (lower[k] - ok) / dk
            b = (upper[k] - ok) / dk
            near = wp.max(near, wp.min(a, b))
            far = wp.min(far, wp.max(a, b))
    if moves and near <= far and (far > wp.float64(FLOAT32_MAX) or near < -wp.float64(FLOAT32_MAX)):
        wp.atomic_add(found, 0, 1)
        wp.atomic_min(found, 1, i)


def _largest_magnitudes(vectors: np.ndarray) -> np.ndarray:
    """``max(|x|, |y|, |z|)`` of each row of ``(N, 3)`` ``vectors``: column by column, as ``max(axis=1)`` over rows of
    three took 5-10 times as long (1M rays: 87-129 ms against 9-18 ms)."""
    size = np.abs(vectors)
    largest = np.maximum(size[:, 0], size[:, 1])
    return np.maximum(largest, size[:, 2], out=largest)


def _may_reach_past_float32(origins, directions, t_mins, t_maxs, reach: float) -> bool:
    """Whether any ray of these host arrays passes the first tests of :func:`count_rays_past_float32_t_kernel`, in
    its float32 arithmetic (NaN rays pass: the kernel passes over them)."""
    half = np.float32(0.5)
    with np.errstate(over="ignore", invalid="ignore"):
        bound = _largest_magnitudes(directions) * (np.float32(FLOAT32_MAX) * np.float32(0.25))
        within = bound >= _largest_magnitudes(origins) * half + np.float32(reach) * half
    return not (within | ((t_maxs <= FLOAT32_MAX) & (t_mins >= -FLOAT32_MAX))).all()


class RaysPastFloat32T:
    """The check of one ray batch against a scene's box: launched when made, read by :meth:`warn` (after the trace
    launches, so no launch waits for it).

    Args:
        scene: the :class:`wrt.Scene` traced (its ``bounds()``; nothing is checked in a scene without geometry).
        rays: ``[origins, directions, t_mins, t_maxs]`` on ``device``, as ``ray_batch.upload_rays`` gives them.
        device: the Warp device they are on.
    """

    def __init__(self, scene, rays: list, device):
        self.rays = rays
        self.found = None
        if not len(rays[0]):
            return
        layout = scene._id_layout()  # cached once traced; stats() sums over every mesh at each call
        if not (layout.instances[-1] or layout.instance_shapes[-1]):  # nothing to hit: every ray misses anyway
            return
        box = np.asarray(scene.bounds(), np.float64)
        reach = float(np.abs(box).max())
        if wp.get_device(device).is_cpu and not _may_reach_past_float32(*(r.numpy() for r in rays), reach):
            return  # the kernel's first test, on the arrays in place: a launch and its read cost more on small batches
        lower, upper = wp.vec3d(*box[0]), wp.vec3d(*box[1])
        self.found = wp.array(np.array([0, len(rays[0])], np.int32), dtype=wp.int32, device=device)
        wp.launch(count_rays_past_float32_t_kernel, len(rays[0]), inputs=[*rays, lower, upper, reach],
                  outputs=[self.found], device=device)

    def warn(self) -> None:
        """Warns naming how many rays pass through the scene's box beyond float32's largest ``t``, and the first."""
        if self.found is None:
            return
        count, first = (int(x) for x in self.found.numpy())
        if not count:
            return
        origin, direction = ("(" + ", ".join(f"{x:.7g}" for x in r[first:first + 1].numpy()[0]) + ")"
                             for r in self.rays[:2])
        warnings.warn(
            f"{count:,} of {len(self.rays[0]):,} rays (the first: row {first}, origin {origin}, direction "
            f"{direction}) pass through the scene's box beyond t = 3.4e38, float32's largest value (or before "
            "-3.4e38): hits there have no float32 t and are reported as misses (or at t = -inf). t is in units of "
            "each direction's length, so a short direction puts near hits at huge t: scale such directions up (only "
            "their orientation matters)",
            stacklevel=user_stacklevel(),
        )
