"""Tracing rays against a scene, through wrt's BVH or through Warp's ``wp.Mesh``, behind one interface.

Both accelerators fill the same hit buffer (``t, u, v, prim``), so shading code and a plain array diff serve
both. ``Hits.t`` is in units of ``|direction|``; barycentrics follow ``hit = (1-u-v) p0 + u p1 + v p2``.
``wp.mesh_query_ray`` reports the weights of ``p0`` and ``p1``; the adapter converts them.
"""

from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from .bvh import DeviceBvh, build_bvh
from .bvh.build import Builder
from .bvh.layout import check_layout, convert_layout, layout_kernels
from .bvh.traverse import bvh_intersect, bvh_occluded
from .scene import Scene

ACCELERATORS = ("wrt", "warp")  # names accepted by accel=
MIN_RAYS_PER_THREAD = 1 << 14  # smaller CPU launches are not split across threads
WARP_BUILDERS = ("sah", "median", "lbvh", "cubql")  # wp.Mesh bvh_constructor values


@wp.kernel
def trace_bvh_kernel(
    bvh: DeviceBvh,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    ts: wp.array[float],
    us: wp.array[float],
    vs: wp.array[float],
    prims: wp.array[wp.int32],
    costs: wp.array[wp.vec2i],
):
    """Closest hit of every ray through wrt's BVH; ``costs`` gets (nodes visited, triangles tested)."""
    i = wp.tid()
    t, u, v, prim, nodes, tests = bvh_intersect(bvh, origins[i], directions[i], t_mins[i], t_maxs[i])
    ts[i] = t
    us[i] = u
    vs[i] = v
    prims[i] = prim
    costs[i] = wp.vec2i(nodes, tests)


@wp.kernel
def occluded_bvh_kernel(
    bvh: DeviceBvh,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    blocked: wp.array[wp.int32],
):
    """1 for every ray that hits anything in ``[t_min, t_max)``."""
    i = wp.tid()
    blocked[i] = wp.where(bvh_occluded(bvh, origins[i], directions[i], t_mins[i], t_maxs[i]), 1, 0)


@wp.func
def mesh_query(mesh: wp.uint64, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """Closest hit through ``wp.mesh_query_ray``, restricted to ``[t_min, t_max)`` and in wrt's conventions."""
    t = float(wp.inf)
    u = float(0.0)
    v = float(0.0)
    prim = int(-1)
    if t_max > t_min:
        # wp.mesh_query_ray accepts t >= 0 only: start the ray at t_min instead.
        q = wp.mesh_query_ray(mesh, origin + t_min * direction, direction, t_max - t_min)
        if q.result:
            t = q.t + t_min
            u = q.v
            v = 1.0 - q.u - q.v
            prim = q.face
    return t, u, v, prim


@wp.kernel
def trace_mesh_kernel(
    mesh: wp.uint64,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    ts: wp.array[float],
    us: wp.array[float],
    vs: wp.array[float],
    prims: wp.array[wp.int32],
    costs: wp.array[wp.vec2i],
):
    """Closest hit of every ray through Warp's ``wp.Mesh`` BVH (costs are not available: written as 0)."""
    i = wp.tid()
    t, u, v, prim = mesh_query(mesh, origins[i], directions[i], t_mins[i], t_maxs[i])
    ts[i] = t
    us[i] = u
    vs[i] = v
    prims[i] = prim
    costs[i] = wp.vec2i(0, 0)


@wp.kernel
def occluded_mesh_kernel(
    mesh: wp.uint64,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    blocked: wp.array[wp.int32],
):
    """1 for every ray that hits anything in ``[t_min, t_max)``, through ``wp.mesh_query_ray_anyhit``."""
    i = wp.tid()
    t_min = t_mins[i]
    hit = False
    if t_maxs[i] > t_min:
        hit = wp.mesh_query_ray_anyhit(mesh, origins[i] + t_min * directions[i], directions[i], t_maxs[i] - t_min)
    blocked[i] = wp.where(hit, 1, 0)


class HitBuffer:
    """Device arrays that trace kernels fill, one entry per ray."""

    def __init__(self, n: int, device):
        self.t = wp.empty(n, dtype=float, device=device)  # distance in units of |direction|, inf on a miss
        self.u = wp.empty(n, dtype=float, device=device)  # barycentric weight of p1
        self.v = wp.empty(n, dtype=float, device=device)  # barycentric weight of p2
        self.prim = wp.empty(n, dtype=wp.int32, device=device)  # triangle id, -1 on a miss
        self.cost = wp.empty(n, dtype=wp.vec2i, device=device)  # (nodes visited, triangles tested)

    @property
    def outputs(self) -> list:
        """The arrays in the order trace kernels take them."""
        return [self.t, self.u, self.v, self.prim, self.cost]

    def slice(self, start: int, end: int) -> HitBuffer:
        """A view of rays ``[start, end)``."""
        view = HitBuffer.__new__(HitBuffer)
        view.t, view.u, view.v, view.prim, view.cost = (a[start:end] for a in self.outputs)
        return view


def resolve_threads(threads, device) -> int:
    """Worker threads for a launch: 1 on GPUs; all cores for ``None`` on the CPU."""
    if not device.is_cpu:
        return 1
    if threads is None:
        return max(os.cpu_count() or 1, 1)
    if not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads must be a positive integer or None, got {threads!r}")
    return int(threads)


def run_in_chunks(work, n: int, threads: int) -> None:
    """Calls ``work(start, end)`` over ``[0, n)``: in one piece, or in ``threads`` pieces on a thread pool.

    Warp's CPU launches run one kernel on one thread but release the GIL, so pieces of one ray batch run on
    several cores at once. Every ray is independent, so the result does not depend on the split.
    """
    pieces = min(threads, n // MIN_RAYS_PER_THREAD)
    if pieces <= 1:
        work(0, n)
        return
    bounds = np.linspace(0, n, pieces + 1).astype(int)
    with ThreadPoolExecutor(pieces) as pool:
        for future in [pool.submit(work, int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]:
            future.result()


class Accelerator:
    """A ray-scene query structure on one device: closest hit and any hit over ray arrays.

    Subclasses implement ``_intersect`` and ``_occluded`` for one launch; the public methods split CPU launches
    across ``threads`` worker threads.
    """

    name = ""
    device = None

    def intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer, threads=None) -> None:
        """Fills ``hits`` with the closest hit of each ray (all arguments are device arrays)."""

        def work(a, b):
            self._intersect(origins[a:b], directions[a:b], t_mins[a:b], t_maxs[a:b], hits.slice(a, b))

        run_in_chunks(work, len(origins), resolve_threads(threads, wp.get_device(self.device)))

    def occluded(self, origins, directions, t_mins, t_maxs, blocked, threads=None) -> None:
        """Sets ``blocked[i] = 1`` where ray ``i`` hits anything."""

        def work(a, b):
            self._occluded(origins[a:b], directions[a:b], t_mins[a:b], t_maxs[a:b], blocked[a:b])

        run_in_chunks(work, len(origins), resolve_threads(threads, wp.get_device(self.device)))

    def _intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer) -> None:
        raise NotImplementedError

    def _occluded(self, origins, directions, t_mins, t_maxs, blocked) -> None:
        raise NotImplementedError


class BvhAccelerator(Accelerator):
    """wrt's own BVH, in one of the layouts of ``wrt.bvh.layout.LAYOUTS`` (all give identical hits)."""

    name = "wrt"
    layout = "binary"  # the canonical FlatBvh; other layouts are conversions with their own kernels
    trace_kernel = trace_bvh_kernel
    occluded_kernel = occluded_bvh_kernel

    def __init__(self, scene: Scene, builder: str, device, layout: str = "binary", **build_options):
        points, indices = scene.triangles()
        self.bvh = build_bvh(points, indices, builder, device=device, **build_options)
        self.layout = check_layout(layout)
        self.device_bvh = convert_layout(self.bvh, layout).to_device(points, indices, device)
        if layout != "binary":
            self.trace_kernel, self.occluded_kernel = layout_kernels(layout)
        self.device = device

    def _intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer) -> None:
        wp.launch(
            self.trace_kernel,
            len(origins),
            inputs=[self.device_bvh, origins, directions, t_mins, t_maxs],
            outputs=hits.outputs,
            device=self.device,
        )

    def _occluded(self, origins, directions, t_mins, t_maxs, blocked) -> None:
        wp.launch(
            self.occluded_kernel,
            len(origins),
            inputs=[self.device_bvh, origins, directions, t_mins, t_maxs],
            outputs=[blocked],
            device=self.device,
        )


class WarpMeshAccelerator(Accelerator):
    """Warp's builtin ``wp.Mesh`` BVH, for comparison."""

    name = "warp"

    def __init__(self, scene: Scene, builder: str, device):
        if builder not in WARP_BUILDERS:
            raise ValueError(f"wp.Mesh has no builder {builder!r}; valid builders for accel='warp': {WARP_BUILDERS}")
        points, indices = scene.triangles()
        self.device = device
        self.num_prims = len(indices)
        if self.num_prims == 0:
            self.mesh = None
            return
        self.points = wp.array(points, dtype=wp.vec3, device=device)
        self.indices = wp.array(indices.reshape(-1), dtype=wp.int32, device=device)
        self.mesh = wp.Mesh(self.points, self.indices, bvh_constructor=builder)

    def _launch(self, kernel, n, inputs, outputs, miss_fill) -> None:
        if self.mesh is None:
            for array, value in zip(outputs, miss_fill):
                array.fill_(value)
            return
        wp.launch(kernel, n, inputs=[self.mesh.id, *inputs], outputs=outputs, device=self.device)

    def _intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer) -> None:
        misses = [np.inf, 0.0, 0.0, -1, wp.vec2i(0, 0)]
        self._launch(trace_mesh_kernel, len(origins), [origins, directions, t_mins, t_maxs], hits.outputs, misses)

    def _occluded(self, origins, directions, t_mins, t_maxs, blocked) -> None:
        self._launch(occluded_mesh_kernel, len(origins), [origins, directions, t_mins, t_maxs], [blocked], [0])


def get_accelerator(
    scene: Scene, accel: str = "wrt", builder: str = "sah", device=None, layout: str = "binary"
) -> Accelerator:
    """The accelerator for ``scene`` on ``device``, built on first use and cached on the scene.

    Raises:
        ValueError: for an unknown ``accel``, ``builder`` or ``layout`` (layouts other than ``binary`` are wrt's).
    """
    if accel not in ACCELERATORS:
        raise ValueError(f"unknown accelerator {accel!r}; valid accelerators: {', '.join(ACCELERATORS)}")
    check_layout(layout)
    if accel == "wrt":
        builder = Builder.from_str(builder).value  # "binned_sah" and "sah" share one cached tree
    elif layout != "binary":
        raise ValueError(f"layout={layout!r} applies to accel='wrt' only; wp.Mesh has its own layout")
    device = resolve_device(device)
    key = ("accel", accel, builder, str(device)) + (() if layout == "binary" else (layout,))
    if key not in scene._cache:
        if accel == "wrt":
            scene._cache[key] = BvhAccelerator(scene, builder, device, layout)
        else:
            scene._cache[key] = WarpMeshAccelerator(scene, "sah" if builder == "binned_sah" else builder, device)
    return scene._cache[key]


def resolve_device(device) -> wp.Device:
    """``wp.get_device`` with a one-line ``ValueError`` naming the available devices."""
    try:
        return wp.get_device(device)
    except (RuntimeError, ValueError, TypeError) as e:
        available = ", ".join(d.alias for d in wp.get_devices())
        raise ValueError(f"unknown or unavailable device {device!r}; available devices: {available}") from e


@dataclasses.dataclass
class Hits:
    """Closest hits of a batch of rays, as numpy arrays of length N.

    Attributes:
        t: float32 distance in units of ``|direction|``; ``inf`` on a miss.
        u: float32 barycentric weight of the triangle's second vertex.
        v: float32 barycentric weight of the third vertex: ``hit = (1-u-v) p0 + u p1 + v p2``.
        prim: int32 row of ``Scene.triangles()``, -1 on a miss.
        nodes_visited: int32 BVH nodes visited per ray (0 for ``accel="warp"``).
        triangles_tested: int32 ray-triangle tests per ray (0 for ``accel="warp"``).
    """

    t: np.ndarray
    u: np.ndarray
    v: np.ndarray
    prim: np.ndarray
    nodes_visited: np.ndarray
    triangles_tested: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        """bool mask of rays that hit."""
        return self.prim >= 0


def _as_rays(origins, directions) -> tuple[np.ndarray, np.ndarray]:
    o = np.asarray(origins, dtype=np.float32)
    d = np.asarray(directions, dtype=np.float32)
    if o.ndim != 2 or o.shape[1] != 3 or d.shape != o.shape:
        raise ValueError(f"origins and directions must both be (N, 3) arrays, got {o.shape} and {d.shape}")
    return np.ascontiguousarray(o), np.ascontiguousarray(d)


def _upload_rays(origins, directions, t_max, device) -> list:
    """Checks and uploads a ray batch: ``[origins, directions, t_mins (zeros), t_maxs]`` as device arrays."""
    o, d = _as_rays(origins, directions)
    n = len(o)
    t_maxs = np.broadcast_to(np.asarray(t_max, dtype=np.float32), (n,)).copy()
    return [
        wp.array(o, dtype=wp.vec3, device=device),
        wp.array(d, dtype=wp.vec3, device=device),
        wp.zeros(n, dtype=float, device=device),
        wp.array(t_maxs, dtype=float, device=device),
    ]


def trace(
    scene: Scene,
    origins,
    directions,
    *,
    t_max=np.inf,
    accel: str = "wrt",
    builder: str = "sah",
    device="cpu",
    threads: int | None = None,
    layout: str = "binary",
) -> Hits:
    """Closest hit of each ray ``origins[i] + t * directions[i]``, ``0 <= t < t_max``.

    Args:
        scene: the scene to trace against.
        origins: ``(N, 3)`` float32, world space.
        directions: ``(N, 3)`` float32, world space; need not be unit length. Zero or NaN directions miss.
        t_max: scalar or ``(N,)`` upper bound on ``t`` (exclusive).
        accel: ``"wrt"`` (own BVH) or ``"warp"`` (``wp.Mesh`` + ``wp.mesh_query_ray``).
        builder: BVH builder name; for ``accel="warp"`` one of Warp's constructors.
        device: Warp device to trace on.
        threads: CPU worker threads (``None``: all cores); ignored on GPUs.
        layout: node layout of wrt's BVH: ``binary``, ``compact``, ``wide`` (BVH4) or ``wide8``; same hits.

    Returns:
        :class:`Hits` with numpy arrays.
    """
    acc = get_accelerator(scene, accel, builder, device, layout)
    rays = _upload_rays(origins, directions, t_max, acc.device)
    hits = HitBuffer(len(rays[0]), acc.device)
    if len(rays[0]):
        acc.intersect(*rays, hits, threads=threads)
    cost = hits.cost.numpy().reshape(-1, 2)
    return Hits(hits.t.numpy(), hits.u.numpy(), hits.v.numpy(), hits.prim.numpy(), cost[:, 0].copy(), cost[:, 1].copy())


def occluded(
    scene: Scene,
    origins,
    directions,
    *,
    t_max=np.inf,
    accel="wrt",
    builder="sah",
    device="cpu",
    threads=None,
    layout: str = "binary",
) -> np.ndarray:
    """Any-hit query: ``(N,)`` bool, True where ray ``i`` hits something with ``0 <= t < t_max``. The arguments
    are those of :func:`trace`."""
    acc = get_accelerator(scene, accel, builder, device, layout)
    rays = _upload_rays(origins, directions, t_max, acc.device)
    blocked = wp.zeros(len(rays[0]), dtype=wp.int32, device=acc.device)
    if len(rays[0]):
        acc.occluded(*rays, blocked, threads=threads)
    return blocked.numpy().astype(bool)
