"""Tracing rays against a scene, through wrt's BVH or through Warp's ``wp.Mesh``, behind one interface.

Both accelerators fill the same hit buffer (``t, u, v, prim, instance``), so shading code and a plain array diff
serve both. ``Hits.t`` is in units of ``|direction|``; barycentrics follow ``hit = (1-u-v) p0 + u p1 + v p2``.
``wp.mesh_query_ray`` reports the weights of ``p0`` and ``p1``; the adapter converts them.

Instancing: in a hit buffer ``prim`` is a geometry id (a row of :meth:`wrt.Scene.geometry`, where each prototype's
triangles appear once) and ``instance`` the instance hit (-1 for non-instanced geometry). For scenes with instances
``accel="wrt"`` is the two-level BVH of :mod:`wrt.tlas`; ``accel="warp"`` has no instancing and traces
``Scene.triangles()`` flattened (up to :data:`WARP_MAX_TRIANGLES`), then maps its rows back to
``(geometry id, instance)``. :func:`trace` reports rows of ``Scene.triangles()`` in ``Hits.prim`` either way.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import os
import time
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np
import warp as wp

from .bvh import DeviceBvh, FlatBvh, build_bvh, build_bvh_device, traverse
from .bvh.build import Builder
from .bvh.common import check_triangles, resolve_device
from .bvh.compact import device_compact_bvh
from .bvh.layout import check_layout, convert_layout, layout_kernels
from .bvh.stack import STACK_BUILD_OPTIONS
from .bvh.traverse import any_hit_kernel, bvh_intersect, bvh_occluded, closest_hit_kernels
from .bvh.warp_mesh import WARP_BUILDERS
from .bvh.wide import WIDE_WIDTHS, device_wide_bvh
from .errors import did_you_mean, stray_field, user_stacklevel
from .instancing import Instances, unplaceable
from .mesh_trace import occluded_mesh_kernel, trace_mesh_kernel
from .options import ACCELERATOR_PRESPLIT, ACCELERATORS
from .ray_batch import upload_rays
from .ray_reach import RaysPastFloat32T
from .scene import IdRows, Scene
from .traced_in import TracedIn

# No floating-point contraction (FMA) in the trace kernels: the watertight triangle test relies on an edge shared by
# two triangles giving exactly opposite edge functions (``cx * by - cy * bx``), which a fused multiply-add breaks;
# and nvrtc and clang fuse different operations, so CUDA and CPU hits would differ near edges. No backward pass:
# nothing differentiates a trace, and the adjoint kernels doubled the code compiled at the first render (the forward
# kernels are the same code either way).
wp.set_module_options({"fuse_fp": False, "enable_backward": False})
wp.set_module_options({"extra_build_options": STACK_BUILD_OPTIONS})  # the traversal stack type's C++ code

MIN_RAYS_PER_THREAD = 1 << 14  # smaller CPU launches are not split across threads
WARP_MAX_TRIANGLES = 1 << 27  # accel="warp" flattens instances; larger instanced scenes are refused


trace_bvh_kernel, trace_bvh_kernel_uncounted = closest_hit_kernels(
    bvh_intersect, DeviceBvh, "trace_bvh_kernel", __name__
)


occluded_bvh_kernel = any_hit_kernel(bvh_occluded, DeviceBvh, "occluded_bvh_kernel", __name__)


@wp.kernel
def split_rows_kernel(
    offsets: wp.array[wp.int64],
    instance_first: wp.array[wp.int32],
    instance_mirrored: wp.array[wp.int32],
    num_flat: int,
    # outputs
    us: wp.array[float],
    vs: wp.array[float],
    prims: wp.array[wp.int32],
    instances: wp.array[wp.int32],
):
    """Rows of ``Scene.triangles()`` -> ``(geometry id, instance)``, with ``u, v`` swapped back on mirrored
    instances (whose rows have their corners 1 and 2 swapped). ``offsets`` is ``Scene.instance_offsets()``."""
    i = wp.tid()
    row = prims[i]
    instances[i] = -1
    if row < num_flat:
        return
    # Binary search for the instance whose rows contain this one.
    lo = int(0)
    hi = offsets.shape[0] - 1
    r = wp.int64(row)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if offsets[mid] <= r:
            lo = mid
        else:
            hi = mid
    prims[i] = instance_first[lo] + int(r - offsets[lo])
    instances[i] = lo
    if instance_mirrored[lo] == 1:
        u = us[i]
        us[i] = vs[i]
        vs[i] = u


class HitBuffer:
    """Device arrays that trace kernels fill, one entry per ray."""

    BYTES_PER_RAY = 4 * 3 + 4 + 8 + 4  # t, u, v; prim; cost; instance

    def __init__(self, n: int, device):
        self.t = wp.empty(n, dtype=float, device=device)  # distance in units of |direction|, inf on a miss
        self.u = wp.empty(n, dtype=float, device=device)  # barycentric weight of p1
        self.v = wp.empty(n, dtype=float, device=device)  # barycentric weight of p2
        self.prim = wp.empty(n, dtype=wp.int32, device=device)  # geometry id (Scene.geometry() row), -1 on a miss
        self.cost = wp.empty(n, dtype=wp.vec2i, device=device)  # (nodes visited, triangles tested)
        self.instance = wp.full(n, -1, dtype=wp.int32, device=device)  # instance hit, -1: none (kept by non-
        # instanced accelerators, which never write it)

    @property
    def outputs(self) -> list:
        """The arrays in the order trace kernels take them (``instance`` is not among them: only instancing
        accelerators write it, as an extra output)."""
        return [self.t, self.u, self.v, self.prim, self.cost]

    def slice(self, start: int, end: int) -> HitBuffer:
        """A view of rays ``[start, end)``."""
        view = HitBuffer.__new__(HitBuffer)
        view.t, view.u, view.v, view.prim, view.cost = (a[start:end] for a in self.outputs)
        view.instance = self.instance[start:end]
        return view


def resolve_threads(threads, device) -> int:
    """Worker threads for a launch: 1 on GPUs; on the CPU ``threads``, or for ``None`` the ``WRT_THREADS``
    environment variable (a number or ``all``), else every core. A bad ``threads`` raises on every device, so a
    script that passes one fails on the CPU and on a GPU alike (``WRT_THREADS`` is read on the CPU only)."""
    if device.is_cpu:
        return _thread_count(threads)
    if threads is not None:
        _thread_count(threads)
    return 1


def _thread_count(threads) -> int:
    """:func:`resolve_threads` for the CPU."""
    source = "threads"  # named in the error, so a bad environment variable is not reported as the argument
    if threads is None:
        threads = os.environ.get("WRT_THREADS", "all").strip()
        source = "the WRT_THREADS environment variable"
    if threads == "all":
        return max(os.cpu_count() or 1, 1)
    given = threads
    # isdecimal, not isdigit: "²" is a digit that int() refuses, with its own message naming neither source.
    if isinstance(threads, str) and threads.isdecimal():
        threads = int(threads)
    # A bool is an int to Python: threads=True would quietly mean one thread.
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) or threads < 1:
        expected = "a positive integer or 'all'" if source != "threads" else "a positive integer, 'all' or None"
        raise ValueError(f"{source} must be {expected}, got {given!r}")
    return int(threads)


def chunk_count(n: int, threads: int) -> int:
    """Pieces :func:`run_in_chunks` splits ``n`` rays into for ``threads`` threads: at most one per
    :data:`MIN_RAYS_PER_THREAD` rays, at least one."""
    return max(min(threads, n // MIN_RAYS_PER_THREAD), 1)


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system has one, else every core): threads past
    it take turns."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # macOS, Windows
        return max(os.cpu_count() or 1, 1)


def run_in_chunks(work, n: int, threads: int, kernels=()) -> None:
    """Calls ``work(start, end)`` over ``[0, n)``: in one piece, or in ``threads`` pieces on a thread pool.

    Warp's CPU launches run one kernel on one thread but release the GIL, so pieces of one ray batch run on
    several cores at once. Every ray is independent, so the result does not depend on the split.

    ``kernels`` are those ``work`` launches: their modules are loaded here before the pieces start. Warp compiles a
    module at the first launch of any of its kernels, and threads that reach it together each compiled it: on an
    empty kernel cache every core compiled the trace and integrator modules at once, a first render of the
    default scene compiling ``wrt.trace`` and ``wrt.integrators.whitted`` twice on two cores.
    """
    pieces = chunk_count(n, threads)
    if pieces <= 1:
        work(0, n)
        return
    for kernel in kernels:
        wp.load_module(kernel.module, device="cpu")  # pieces only on the CPU (resolve_threads)
    bounds = np.linspace(0, n, pieces + 1).astype(int)
    with ThreadPoolExecutor(pieces) as pool:
        for future in [pool.submit(work, int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]:
            future.result()


class Accelerator:
    """A ray-scene query structure on one device: closest hit and any hit over ray arrays.

    Subclasses implement ``_intersect`` and ``_occluded`` for one launch; the public methods split CPU launches
    across ``threads`` worker threads.

    Costs: a closest-hit query fills ``HitBuffer.cost`` with each ray's (nodes visited, triangles tested) when
    ``costs=True``. With ``costs=False`` wrt's BVH runs kernels that count nothing and leave ``cost`` as it was:
    the two counters stay live through the whole traversal loop at the kernels' 64-register cap, and without them
    (and with ``bvh.traverse.reported_hit``) the BVH4 traced 6-8% faster on an H200 (GPU_NOTES.md, rows 37-38).
    Renders count the camera rays only (the cost AOV); ``wp.Mesh`` never counts.

    Limits are taken as the float32 arrays given. Kernels with ``unit_rays`` scale them with each ray's direction
    (``traverse.unit_ray``), which rounds a limit whose product with ``|direction|`` is below float32's normal range
    (1e-38): ``ray_batch.upload_rays(..., unit_rays=True)`` prepares arrays for them, as :func:`trace` does. Renders
    (``hidden_hits.intersect_visible``, shadow and cull passes) and ``wrt bench`` call these methods with limits as
    their kernels compute them, unrounded: their directions are unit length, whose limits ``unit_ray`` scales by 1 or
    1/2, so only a limit below 2^-125 could round, and theirs are 0, inf, clipping distances, light distances or a
    culled hit's ``t`` plus at least 2^-125 (``hidden_hits.t_past``).
    """

    name = ""
    device = None
    unit_rays = False  # whether the kernels trace each ray scaled by traverse.unit_ray (ray_batch rounds limits for it)

    def intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer, threads=None, costs=True) -> None:
        """Fills ``hits`` with the closest hit of each ray (all arguments are device arrays); ``hits.cost`` only
        with ``costs`` (see the class docstring)."""

        def work(a, b):
            self._intersect(origins[a:b], directions[a:b], t_mins[a:b], t_maxs[a:b], hits.slice(a, b), costs)

        run_in_chunks(work, len(origins), resolve_threads(threads, wp.get_device(self.device)), self.kernels(costs))

    def occluded(self, origins, directions, t_mins, t_maxs, blocked, threads=None) -> None:
        """Sets ``blocked[i] = 1`` where ray ``i`` hits anything."""

        def work(a, b):
            self._occluded(origins[a:b], directions[a:b], t_mins[a:b], t_maxs[a:b], blocked[a:b])

        run_in_chunks(work, len(origins), resolve_threads(threads, wp.get_device(self.device)), self.kernels(None))

    def kernels(self, costs) -> tuple:
        """The kernels that ``_intersect`` (``costs`` True or False) or ``_occluded`` (``costs=None``) launch (see
        :func:`run_in_chunks`)."""
        return ()

    def _intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer, costs: bool) -> None:
        raise NotImplementedError

    def _occluded(self, origins, directions, t_mins, t_maxs, blocked) -> None:
        raise NotImplementedError


def check_flattenable(scene: Scene, what: str) -> None:
    """Raises ``ValueError`` when ``what`` (an accelerator without instancing) cannot trace ``scene``: it has
    analytic shapes, or flattening its instances would exceed :data:`WARP_MAX_TRIANGLES` triangles."""
    stats = scene.stats()
    if stats["rendered_shapes"]:
        raise ValueError(
            f"{what} traces triangles only and this scene has {stats['rendered_shapes']} analytic shape(s); "
            "use accel='wrt' (binary layout), or load it with tessellate_gprims=True"
        )
    rendered = stats["rendered_triangles"]
    if len(scene.instances) and rendered > WARP_MAX_TRIANGLES:
        raise ValueError(
            f"{what} has no instancing and would flatten {rendered:,} triangles (more than "
            f"{WARP_MAX_TRIANGLES:,}); use accel='wrt' (binary layout), which builds one BVH per prototype"
        )


def check_finite_transforms(scene: Scene) -> None:
    """Raises ``ValueError`` naming the first instance whose prototype index is not a row of the scene's prototypes
    (:meth:`Scene.check_prototype_indices`), the first instance or shape whose transform holds a NaN or inf, the first
    instance placed beyond float32's range (:func:`wrt.instancing.unplaceable`), then the first shape or instance
    whose transform takes its box past that range (:meth:`Scene.check_shape_boxes`, ``check_instance_boxes``).
    Such an instance cannot be inverted or placed on a device: the two-level BVH left it out as a zero scale, so it
    vanished without a word, and the flattened copies that the other layouts and ``wp.Mesh`` trace dropped it too,
    or refused the NaN triangle rows it became, naming only a row (the USD loader warns about the singular instances
    it skips; scenes built in Python reach here unchecked)."""
    scene.check_prototype_indices()  # an accelerator built directly named a bad index's translation, not the index
    instances = scene.instances
    bad = np.flatnonzero(unplaceable(instances.to_world))
    if len(bad):
        i = int(bad[0])
        if np.isfinite(instances.to_world[i]).all():
            raise ValueError(f"instance {i} ({instances.path(i)}) is placed beyond float32's range (translation "
                             f"{instances.to_world[i, :3, 3].tolist()}, |x| > 3.4e38), and rays are traced in float32")
        raise ValueError(f"instance {i} ({instances.path(i)}) has a NaN or infinite transform")
    for shape in [*scene.shapes, *(s for p in scene.prototypes for s in p.shapes)]:
        if not np.isfinite(shape.to_world).all():
            raise ValueError(f"shape {shape.path} has a NaN or infinite transform")
    scene.check_shape_boxes()  # a box past float32 (a radius of 1e39): the build named no shape
    scene.check_instance_boxes()  # a scale that takes its prototype past float32: the build named a triangle row


class RowSplitter:
    """Maps hits on the flattened ``Scene.triangles()`` of an instanced scene back to ``(geometry id, instance)``
    in a hit buffer (see :func:`split_rows_kernel`)."""

    def __init__(self, scene: Scene, device):
        ranges = scene.prototype_ranges()
        self.device = device
        self.inputs = [
            wp.array(scene.instance_offsets(), dtype=wp.int64, device=device),
            wp.array(ranges[:, 0][scene.instances.prototype].astype(np.int32), dtype=wp.int32, device=device),
            wp.array(scene.instances.mirrored.astype(np.int32), dtype=wp.int32, device=device),
            scene.num_flat_triangles,
        ]

    def __call__(self, hits: HitBuffer) -> None:
        wp.launch(
            split_rows_kernel,
            len(hits.t),
            inputs=self.inputs,
            outputs=[hits.u, hits.v, hits.prim, hits.instance],
            device=self.device,
            # The trace kernels' block size: Warp builds a module once per block size, so Warp's default here built
            # all of wrt.trace a second time on CUDA.
            block_dim=traverse.trace_block_dim(self.device),
        )


def accelerator_build_options(builder: str, given: dict) -> dict:
    """``given`` build options with the defaults of the trees that traces and renders build: SAH trees with
    :data:`ACCELERATOR_PRESPLIT` pre-splits (``presplit=0`` turns them off). One rule for :class:`BvhAccelerator`
    and the BLASes of :class:`wrt.tlas.InstancedAccelerator`, whose trees were built without them."""
    if Builder.from_str(builder) is Builder.SAH:  # "binned_sah" too
        return {"presplit": ACCELERATOR_PRESPLIT, **given}
    return dict(given)


class BvhAccelerator(Accelerator):
    """wrt's own BVH, in one of the layouts of ``wrt.bvh.layout.LAYOUTS`` (all give identical hits). On a scene with
    instances it traces the flattened ``Scene.triangles()`` (layouts other than binary have no instancing)."""

    name = "wrt"
    unit_rays = True
    layout = "binary"  # the canonical FlatBvh; other layouts are conversions with their own kernels
    trace_kernel = trace_bvh_kernel
    uncounted_trace_kernel = trace_bvh_kernel_uncounted
    occluded_kernel = occluded_bvh_kernel
    split = None  # RowSplitter of an instanced scene
    _layout_size = None  # (nodes, bytes) of the traced layout, once known (see layout_size)

    def __init__(self, scene: Scene, builder: str, device, layout: str = "binary", **build_options):
        check_flattenable(scene, f"layout={layout!r}")
        check_finite_transforms(scene)
        build_options = accelerator_build_options(builder, build_options)
        self.split = RowSplitter(scene, device) if len(scene.instances) else None
        points, indices = scene.triangles()
        self.layout = check_layout(layout)
        if wp.get_device(device).is_cuda and (layout == "binary" or len(indices)):
            self._build_on_device(points, indices, builder, device, build_options)
        else:
            self.bvh = build_bvh(points, indices, builder, device=device, **build_options)
            traced = convert_layout(self.bvh, layout)
            self.device_bvh = traced.to_device(points, indices, device)
            self._layout_size = (int(traced.num_nodes), int(traced.bytes))
        if layout != "binary":
            self.trace_kernel, self.occluded_kernel = layout_kernels(layout)
            self.uncounted_trace_kernel = layout_kernels(layout, counted=False)[0]
        self.device = device
        self._refitter = None

    def refit(self, scene: Scene) -> None:
        """Follows ``scene``'s vertices (same triangles as the build): the nodes stay, their boxes are recomputed
        (:mod:`wrt.bvh.refit`); layouts other than binary are converted again from the refitted tree."""
        from .bvh.refit import Refitter

        points, indices = scene.triangles()
        if self.split is not None:
            # Instances that turned mirrored (or back) swapped corners 1 and 2 in triangles(); the mapping back
            # to prototype barycentrics must follow, or u and v come out swapped on their triangles.
            self.split = RowSplitter(scene, self.device)
        if self.layout == "binary":
            self._refitter = self._refitter or Refitter(self.bvh, self.device_bvh, self.device)
            self._refitter.refit(points, indices)
        else:
            Refitter(self.bvh, self.bvh.to_device(points, indices, self.device), self.device).refit(points, indices)
            self.device_bvh = convert_layout(self.bvh, self.layout).to_device(points, indices, self.device)

    def _build_on_device(self, points, indices, builder, device, build_options) -> None:
        """Every layout on a GPU: the tree, its conversion and its triangles in slot order never leave the device (a
        round trip through numpy costs more than a GPU build); :attr:`bvh` copies the tree to the host when first
        asked."""
        start = time.perf_counter()
        points_d = wp.array(points, dtype=wp.vec3, device=device)
        indices_d = wp.array(indices, dtype=wp.int32, device=device)
        self._device_tree = build_bvh_device(points_d, indices_d, builder, device=device, **build_options)
        if self.layout == "binary":
            self.device_bvh = self._device_tree.to_device_bvh(points_d, indices_d)
        elif self.layout == "compact":
            self.device_bvh = device_compact_bvh(self._device_tree, points_d, indices_d)
        else:
            self.device_bvh = device_wide_bvh(self._device_tree, points_d, indices_d, WIDE_WIDTHS[self.layout])
        self._host_inputs = (points, indices, time.perf_counter() - start)

    @property
    def layout_size(self) -> tuple[int, int]:
        """``(nodes, bytes)`` of the layout traced, as ``wrt bvh-stats --layout`` counts them: those of the conversion
        made for the trace, or (a tree built on a GPU) of one made from :attr:`bvh` when first asked."""
        if self._layout_size is None:
            traced = convert_layout(self.bvh, self.layout)
            self._layout_size = (int(traced.num_nodes), int(traced.bytes))
        return self._layout_size

    @functools.cached_property
    def bvh(self) -> FlatBvh:
        """The canonical tree on the host (stats, previews, refits); a tree built on a GPU is copied on first use."""
        bvh = self._device_tree.to_host()
        bvh.points, bvh.indices, bvh.build_seconds = self._host_inputs
        return bvh

    def kernels(self, costs) -> tuple:
        if costs is None:
            return (self.occluded_kernel,)
        kernel = self.trace_kernel if costs else self.uncounted_trace_kernel
        return (kernel,) if self.split is None else (kernel, split_rows_kernel)

    def _intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer, costs: bool) -> None:
        wp.launch(
            self.trace_kernel if costs else self.uncounted_trace_kernel,
            len(origins),
            inputs=[self.device_bvh, origins, directions, t_mins, t_maxs],
            outputs=hits.outputs,
            device=self.device,
            block_dim=traverse.trace_block_dim(self.device),
        )
        if self.split is not None:
            self.split(hits)

    def _occluded(self, origins, directions, t_mins, t_maxs, blocked) -> None:
        wp.launch(
            self.occluded_kernel,
            len(origins),
            inputs=[self.device_bvh, origins, directions, t_mins, t_maxs],
            outputs=[blocked],
            device=self.device,
            block_dim=traverse.trace_block_dim(self.device),
        )


def mesh_box(points) -> list:
    """``[lower, upper]`` (``wp.vec3``) of the finite ``points`` ``(V, 3)`` of a ``wp.Mesh`` (its triangles use no
    others: ``check_triangles``): the box that ``trace_mesh_kernel`` and ``occluded_mesh_kernel`` take after the
    mesh id, where queries with a negative ``t_min`` start (``mesh_query_start``)."""
    points = np.asarray(points, np.float32).reshape(-1, 3)
    finite = points[np.isfinite(points).all(axis=1)]
    return [wp.vec3(*finite.min(axis=0)), wp.vec3(*finite.max(axis=0))]


class WarpMeshAccelerator(Accelerator):
    """Warp's builtin ``wp.Mesh`` BVH, for comparison. Its kernels trace each ray scaled by ``traverse.unit_ray``,
    as wrt's do: unscaled, ``wp.mesh_query_ray`` missed every ray whose direction's components were all below about
    1e-38 (their inverses overflow), ``(0, 0, -1e-39)`` straight down onto a triangle among them."""

    name = "warp"
    unit_rays = True

    def __init__(self, scene: Scene, builder: str, device):
        if builder not in WARP_BUILDERS:
            raise ValueError(f"wp.Mesh has no builder {builder!r}{did_you_mean(builder, WARP_BUILDERS)}; valid "
                             f"builders for accel='warp': {WARP_BUILDERS}")
        check_flattenable(scene, "accel='warp'")
        self.device = device
        if builder == "lbvh" and wp.get_device(device).is_cpu:  # said in wrt's words: Warp's named no option
            import warnings

            warnings.warn("accel='warp' with builder='lbvh': wp.Mesh has no lbvh builder on the CPU, so it builds its "
                          "sah tree, which finds the same hits", stacklevel=user_stacklevel())
            builder = "sah"
        self.builder = builder
        self._build(scene)

    def _build(self, scene: Scene) -> None:
        check_finite_transforms(scene)
        points, indices = scene.triangles()
        self.split = RowSplitter(scene, self.device) if len(scene.instances) else None
        self.num_prims = len(indices)
        if self.num_prims == 0:
            self.mesh = None
            return
        self.points = wp.array(points, dtype=wp.vec3, device=self.device)
        self.indices = wp.array(indices.reshape(-1), dtype=wp.int32, device=self.device)
        # wp.Mesh takes NaN and inf vertices without a word and its rays then slip through holes: checked as wrt's
        # own builds check them.
        check_triangles(self.points, self.indices.reshape((-1, 3)))
        self.mesh = wp.Mesh(self.points, self.indices, bvh_constructor=self.builder)
        self.box = mesh_box(points)

    def refit(self, scene: Scene) -> None:
        """Follows ``scene``'s vertices by building the ``wp.Mesh`` again: ``wp.Mesh.refit`` keeps its old tree,
        whose visiting order decides which of two hits at exactly the same ``t`` it reports, so a refitted frame
        differed from a fresh render of the same time. Non-finite vertices raise ``ValueError`` as in the build."""
        self._build(scene)

    def _launch(self, kernel, n, inputs, outputs, miss_fill) -> None:
        if self.mesh is None:
            for array, value in zip(outputs, miss_fill):
                array.fill_(value)
            return
        wp.launch(kernel, n, inputs=[self.mesh.id, *self.box, *inputs], outputs=outputs, device=self.device,
                  block_dim=traverse.trace_block_dim(self.device))

    def kernels(self, costs) -> tuple:
        if self.mesh is None:  # no triangles: nothing is launched
            return ()
        if costs is None:
            return (occluded_mesh_kernel,)
        return (trace_mesh_kernel,) if self.split is None else (trace_mesh_kernel, split_rows_kernel)

    def _intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer, costs: bool) -> None:
        misses = [np.inf, 0.0, 0.0, -1, wp.vec2i(0, 0)]
        self._launch(trace_mesh_kernel, len(origins), [origins, directions, t_mins, t_maxs], hits.outputs, misses)
        if self.split is not None and self.mesh is not None:
            self.split(hits)

    def _occluded(self, origins, directions, t_mins, t_maxs, blocked) -> None:
        self._launch(occluded_mesh_kernel, len(origins), [origins, directions, t_mins, t_maxs], [blocked], [0])


def check_scene(scene) -> None:
    """Raises TypeError unless ``scene`` is a :class:`Scene` (a path or None failed with an AttributeError from deep
    inside)."""
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a wrt.Scene (from wrt.load_usd or built in Python), got {type(scene).__name__}")
    stray = stray_field(scene)  # scene.light = [...] (for lights): kept and read by nothing
    if stray:
        raise ValueError(f"scene {stray}")


def moved_accelerator(scene: Scene, key: tuple):
    """The two-level accelerator cached under ``key`` before ``scene``'s instances last moved, followed to them: its
    BLASes kept and its TLAS built anew, as a fresh build's (:meth:`wrt.tlas.InstancedAccelerator.update`); None where
    there is none. Where it cannot follow (other BLASes: an instance's scale crossed ``2^100``, or a prototype's only
    instance was skipped as singular or came back) a new one is built that takes the BLASes it still needs. The
    update is made on a copy: a CUDA graph recorded with the old one keeps replaying the arrays it was recorded with.

    Raises:
        ValueError: for a move the scene refuses (a NaN transform: :func:`check_finite_transforms`). The accelerator
            stays held: the next good move rebuilds the TLAS alone, where it once rebuilt every BLAS.
    """
    held = scene._moved_accels.get(key)
    if held is None:
        return None
    check_finite_transforms(scene)  # first, so that a refused move leaves the held accelerator where it is
    accel = copy.copy(held)
    try:
        accel.update(scene, refit_blas=False)
    except ValueError:  # other BLASes: the ones still needed are taken (a skipped instance rebuilt every BLAS)
        from .tlas import InstancedAccelerator

        accel = InstancedAccelerator(scene, held.builder, held.device, reuse=held)
    del scene._moved_accels[key]
    return accel


def get_accelerator(
    scene: Scene, accel: str = "wrt", builder: str = "sah", device=None, layout: str = "binary"
) -> Accelerator:
    """The accelerator for ``scene`` on ``device``, built on first use and cached on the scene.

    Raises:
        ValueError: for an unknown ``accel``, ``builder`` or ``layout`` (layouts other than ``binary`` are wrt's).
        SceneError: for an instance of a prototype that ``scene`` does not have.
        TypeError: ``scene`` is not a :class:`Scene`.
    """
    check_scene(scene)
    if accel not in ACCELERATORS:
        raise ValueError(f"unknown accelerator {accel!r}{did_you_mean(accel, ACCELERATORS)}; valid accelerators: "
                         f"{', '.join(ACCELERATORS)}")
    check_layout(layout)
    if accel == "wrt":
        builder = Builder.from_str(builder).value  # "binned_sah" and "sah" share one cached tree
    elif layout != "binary":
        raise ValueError(f"layout={layout!r} applies to accel='wrt' only; wp.Mesh has its own layout")
    device = resolve_device(device)
    key = ("accel", accel, builder, str(device)) + (() if layout == "binary" else (layout,))
    with scene.lock:  # a cache drop from another thread waits for this build, which then goes into no fresh cache
        return _cached_accelerator(scene, key, accel, builder, device, layout)


def _cached_accelerator(scene: Scene, key: tuple, accel: str, builder: str, device, layout: str) -> Accelerator:
    """:func:`get_accelerator` once its arguments are checked, with the scene's lock held."""
    scene.drop_stale_caches()  # first: it checks and converts the fields assigned since (instances.to_world = ...)
    scene.check_instances()  # instances may have been set after the Scene was made
    if key not in scene._cache:
        scene.check_vertices()  # named with their mesh here; the builds' own check can name only a row
        scene.warn_past_traced_reach()
        moved = moved_accelerator(scene, key)
        if moved is not None:
            scene._cache[key] = moved
        elif accel == "wrt" and layout == "binary" and (len(scene.instances) or scene.shapes):
            from .tlas import InstancedAccelerator

            scene._cache[key] = InstancedAccelerator(scene, builder, device)
        elif accel == "wrt":
            scene._cache[key] = BvhAccelerator(scene, builder, device, layout)
        else:
            scene._cache[key] = WarpMeshAccelerator(scene, "sah" if builder == "binned_sah" else builder, device)
    return scene._cache[key]


@dataclasses.dataclass
class Hits:
    """Closest hits of a batch of rays, as numpy arrays of length N.

    Attributes:
        t: float32 distance in units of ``|direction|``; ``inf`` on a miss; a hit at the origin is ``0.0``, never
            ``-0.0``.
        u: float32 barycentric weight of the triangle's second vertex.
        v: float32 barycentric weight of the third vertex: ``hit = (1-u-v) p0 + u p1 + v p2``. On an analytic
            shape (a USD gprim: ``Sphere``, ``Cube``, ...) ``u`` and ``v`` are no barycentrics (1/3 on curved
            surfaces): the hit point is ``origin + t * direction``.
        prim: row of ``Scene.triangles()`` (instances expanded), -1 on a miss; int32, or int64 for scenes of more
            than ``2**31 - 1`` rendered triangles. An analytic shape has no row there: its id comes after them,
            ``Scene.stats()["rendered_triangles"] + k`` for the ``k``-th rendered shape (:mod:`wrt.scene`), so
            ``indices[hits.prim]`` of ``Scene.triangles()`` holds triangle hits only (``Scene.hit_paths`` names both).
        nodes_visited: int32 BVH nodes visited per ray, top- and bottom-level together (0 for ``accel="warp"``): the
            nodes whose box the ray enters, each once. The ``compact``, ``wide`` and ``wide8`` layouts keep no box
            for their root, so every ray that can hit counts it (a ray that misses the scene's box: 1, ``binary``:
            0; a tree of one leaf gets a root over it: one more); past the root, ``compact`` counts what ``binary``
            counts, and ``wide``/``wide8`` count their wide nodes (BVH4/BVH8: fewer).
        triangles_tested: int32 ray-primitive tests per ray: triangles, and analytic shapes one test each (0 for
            ``accel="warp"``).
        instance: int32 index into ``Scene.instances`` of the instance hit; -1 on a miss or on non-instanced
            geometry.
        local_prim: int32 geometry id of the hit triangle (row of ``Scene.geometry()``: the prototype's triangle
            for an instance, equal to ``prim`` for non-instanced geometry), -1 on a miss.
        traced_in: the scene, and the state of it, that :func:`trace` traced the hits in
            (:class:`wrt.traced_in.TracedIn`; ``None`` for hits made by hand): the ids above are that scene's, and
            ``Scene.hit_paths`` and ``hit_prims`` refuse them in another scene or after an edit of this one. Kept by
            copies and pickles; not compared by ``==``.
    """

    t: np.ndarray
    u: np.ndarray
    v: np.ndarray
    prim: np.ndarray
    nodes_visited: np.ndarray
    triangles_tested: np.ndarray
    instance: np.ndarray | None = None
    local_prim: np.ndarray | None = None
    traced_in: TracedIn | None = dataclasses.field(default=None, kw_only=True, compare=False, repr=False)

    def __post_init__(self):
        if self.instance is None:
            self.instance = np.full(len(self.prim), -1, np.int32)
        if self.local_prim is None:
            self.local_prim = np.asarray(self.prim, np.int32).copy()

    def __eq__(self, other) -> bool:
        """Whether ``other`` holds the same hits: every array equal, costs included (``np.array_equal``). The
        dataclass compared the arrays with numpy's ``==``, whose answer has no truth value: ``hits == again`` and
        ``hits in results`` raised ValueError."""
        if other.__class__ is not self.__class__:
            return NotImplemented
        return all(np.array_equal(getattr(self, f.name), getattr(other, f.name))
                   for f in dataclasses.fields(self) if f.compare)

    __hash__ = None  # equal by value, and its arrays are mutable

    @property
    def hit(self) -> np.ndarray:
        """bool mask of rays that hit."""
        return self.prim >= 0


def trace(
    scene: Scene,
    origins,
    directions,
    *,
    t_min=0.0,
    t_max=np.inf,
    accel: str = "wrt",
    builder: str = "sah",
    device="cpu",
    threads: int | None = None,
    layout: str = "binary",
) -> Hits:
    """Closest hit of each ray ``origins[i] + t * directions[i]``, ``t_min <= t < t_max``.

    Args:
        scene: the scene to trace against.
        origins: ``(N, 3)`` world space: float32, or anything :mod:`wrt.ray_batch` converts (lists, float64,
            ``wp.array``s on any device, GPU tensors); a ``vec3`` ``wp.array`` on ``device`` is traced in place. A
            ``(3,)`` vector is one ray, and one origin serves every direction.
        directions: ``(N, 3)`` world space, as ``origins``; need not be unit length. Zero or NaN directions miss.
            A hit past ``t = 3.4e38`` (a direction of length 1e-38 and a triangle 1e4 away) has no float32 ``t``: a
            miss, with a warning naming the rays that pass through the scene's box there (:mod:`wrt.ray_reach`).
        t_min: scalar (or ``(1,)``, ``(1, 1)``) or ``(N,)`` (or ``(N, 1)``) lower bound on ``t`` (inclusive; may be
            negative); ``None``: 0.
        t_max: as ``t_min``, the upper bound on ``t`` (exclusive); ``None``: no bound.
        accel: ``"wrt"`` (own BVH) or ``"warp"`` (``wp.Mesh`` + ``wp.mesh_query_ray``).
        builder: BVH builder name; for ``accel="warp"`` one of Warp's constructors.
        device: Warp device to trace on.
        threads: CPU worker threads (``None``: ``$WRT_THREADS``, else every core; ``"all"``: every core); ignored
            on GPUs. Rays are independent, so the hits do not depend on it.
        layout: node layout of wrt's BVH: ``binary``, ``compact``, ``wide`` (BVH4) or ``wide8``; same hits.

    Returns:
        :class:`Hits` with numpy arrays.
    """
    check_scene(scene)  # (a path or None has no lock)
    with scene.lock:  # the hits are read of the scene built, not of an edit another thread made since (HitIds)
        acc = get_accelerator(scene, accel, builder, device, layout)
        ids = hit_ids(scene)
    rays = upload_rays(origins, directions, t_min, t_max, acc.device, acc.unit_rays)
    past_float32 = RaysPastFloat32T(scene, rays, acc.device)
    hits = HitBuffer(len(rays[0]), acc.device)
    if len(rays[0]):
        acc.intersect(*rays, hits, threads=threads)
    result = read_hits(scene, hits, ids)
    past_float32.warn()
    return result


class HitIds(NamedTuple):
    """What :func:`read_hits` reads of a scene, taken with its accelerator under the scene's lock: read after the
    trace, instances mirrored by another thread in the meantime swapped ``u`` and ``v`` of the hits on them, and
    instances replaced named other rows. ``instances`` is a shallow copy (their arrays are replaced, never edited in
    place: frozen); it and ``rows`` are None for a scene without instances or prototypes."""

    instances: Instances | None
    rows: IdRows | None
    traced_in: TracedIn


def hit_ids(scene: Scene) -> HitIds:
    """The :class:`HitIds` of ``scene`` as it is now."""
    if not len(scene.instances) and not scene.prototypes:
        return HitIds(None, None, scene.traced_in)
    return HitIds(copy.copy(scene.instances), scene.id_rows(copy=False), scene.traced_in)


def read_hits(scene: Scene, hits: HitBuffer, ids: HitIds | None = None) -> Hits:
    """The ``Hits`` of a buffer an accelerator of ``scene`` filled: ``prim`` as rows of ``Scene.triangles()``, with
    the barycentrics of those rows (the buffer holds geometry ids and the prototype's corner order); ``ids``: those
    of the scene as it was traced (:func:`hit_ids`; default: as it is now)."""
    ids = hit_ids(scene) if ids is None else ids
    cost = hits.cost.numpy().reshape(-1, 2)
    # + 0.0 turns -0.0 into 0.0 (IEEE: -0 + 0 = +0) and leaves every other t as it is. The kernels' t is a quotient
    # whose signs follow the side a ray leaves from, so a hit at the origin of a ray leaving its surface came back
    # as -0.0 (every accelerator; wp.Mesh with a negative t_min), which 1 / t and np.signbit read as behind it.
    t = hits.t.numpy() + np.float32(0.0)
    u, v, prim = hits.u.numpy(), hits.v.numpy(), hits.prim.numpy()
    if ids.rows is None:
        return Hits(t, u, v, prim, cost[:, 0].copy(), cost[:, 1].copy(), traced_in=ids.traced_in)
    # Report rows of Scene.triangles(): mirrored instances have corners 1 and 2 swapped there. Prototypes count
    # even without instances: their triangles are geometry ids but no rows, so shape ids shift down.
    instance = hits.instance.numpy()
    swap = instance >= 0
    swap[swap] = ids.instances.mirrored_rows(instance[swap])
    u, v = np.where(swap, v, u), np.where(swap, u, v)
    rows = ids.rows.expand(prim, instance)
    return Hits(t, u, v, rows, cost[:, 0].copy(), cost[:, 1].copy(), instance=instance, local_prim=prim,
                traced_in=ids.traced_in)


def occluded(
    scene: Scene,
    origins,
    directions,
    *,
    t_min=0.0,
    t_max=np.inf,
    accel="wrt",
    builder="sah",
    device="cpu",
    threads=None,
    layout: str = "binary",
) -> np.ndarray:
    """Any-hit query: ``(N,)`` bool, True where ray ``i`` hits something with ``t_min <= t < t_max``. The
    arguments are those of :func:`trace`."""
    acc = get_accelerator(scene, accel, builder, device, layout)
    rays = upload_rays(origins, directions, t_min, t_max, acc.device, acc.unit_rays)
    past_float32 = RaysPastFloat32T(scene, rays, acc.device)
    blocked = wp.zeros(len(rays[0]), dtype=wp.int32, device=acc.device)
    if len(rays[0]):
        acc.occluded(*rays, blocked, threads=threads)
    result = blocked.numpy().astype(bool)
    past_float32.warn()
    return result
