"""The BVH builder registry and ``build_bvh``: one API in front of every builder, one canonical result.

Every builder hands over a :class:`FlatBvh` (the canonical binary layout, see ``layout.py``) and nothing else:

- ``sah`` (alias ``binned_sah``): binned SAH on all three axes with SAH leaf termination (``binned.py``);
- ``middle``: spatial median of the centroid box on its widest axis (``binned.py``);
- ``median``: object median on the axis of largest centroid extent (``sweep.py``);
- ``sweep_sah``: full-sweep SAH over presorted centroids on all three axes (``sweep.py``);
- ``lbvh``: Morton codes and a Karras (2012) radix tree (``lbvh.py``);
- ``ploc``: bottom-up agglomerative clustering, PLOC (Meister and Bittner 2018) (``ploc.py``).

All run as Warp kernels on ``cpu`` and ``cuda``. Names match Warp's ``wp.Mesh(bvh_constructor=...)`` where they
mean the same thing (``sah``, ``median``, ``lbvh``). Every builder keeps the depth guarantee of ``common.py``.
"""

from __future__ import annotations

import inspect
import math
import os
import time

import numpy as np
import warp as wp

from ..errors import did_you_mean
from ..options import ALIASES as ALIASES  # re-exported: see wrt.options
from ..options import DEFAULT_BINS, DEFAULT_LEAF_SIZE, MAX_BINS, MAX_LEAF_SIZE, Builder, builder_names
from .common import MAX_DEPTH, BuildInput, resolve_device, stage
from .layout import DeviceFlatBvh, FlatBvh
from .presplit import MAX_SPLIT_LEVELS, References, map_slots_kernel, split_plan, write_references
from .unit_scale import scale_boxes_back, scale_input, unit_exponent


def build_bvh(points, indices, builder: str = "sah", **options) -> FlatBvh:
    """Builds a BVH over triangles and returns it in the canonical flat layout, on the host.

    Args:
        points: ``(V, 3)`` float32 vertex positions, world space; numpy or ``wp.array`` (on ``device`` it is used
            in place).
        indices: ``(T, 3)`` int32 triangle vertex indices, numpy or ``wp.array``.
        builder: a :class:`Builder` name (see module docstring).
        **options: the keyword options of :func:`build_bvh_device` (``leaf_size``, ``bins``, ``traversal_cost``,
            ``intersection_cost``, ``morton_bits``, ``ploc_radius``, ``presplit``, ``threads``, ``device``,
            ``timers``).

    Returns:
        The :class:`FlatBvh`, with ``build_seconds`` set (input checks and host transfers included) and the
        input triangles attached for :meth:`FlatBvh.stats`.

    Raises:
        ValueError: for an unknown builder, bad options, bad indices or non-finite vertices.
    """
    start_time = time.perf_counter()
    valid = [name for name, p in inspect.signature(build_bvh_device).parameters.items() if p.kind is p.KEYWORD_ONLY]
    unknown = [name for name in options if name not in valid]
    if unknown:  # Python's own message named build_bvh_device, a function the caller never called
        raise TypeError(f"build_bvh has no option {unknown[0]!r}{did_you_mean(unknown[0], valid)}; options: "
                        f"{', '.join(valid)}")
    bvh = build_bvh_device(points, indices, builder, **options).to_host()
    bvh.build_seconds = time.perf_counter() - start_time
    bvh.points, bvh.indices = points, indices
    return bvh


def build_bvhs(meshes, builder: str = "sah", **options) -> list[FlatBvh]:
    """:func:`build_bvh` of each ``(points, indices)`` numpy mesh, the same trees; on a CPU device the small ``sah``
    and ``middle`` trees (at most ``batched.BATCH_MAX_TRIANGLES`` triangles, no ``presplit``) are built together
    (``batched.py``): a dozen launches per tree, whatever its size, were most of a small tree's time. GPU builds,
    other builders and larger meshes are built one by one, as before.

    Raises:
        as :func:`build_bvh`, for the first mesh it refuses.
    """
    from .batched import batch_groups, batchable, build_binned_batch

    trees: list = [None] * len(meshes)
    device = resolve_device(options.get("device"))
    kind = Builder.from_str(builder)
    batch = []
    start_time = time.perf_counter()
    if device.is_cpu and kind in (Builder.SAH, Builder.MIDDLE) and not options.get("presplit") and not set(
        options) - {"leaf_size", "bins", "traversal_cost", "intersection_cost", "threads", "device"}:
        batch = [j for j, (p, i) in enumerate(meshes) if batchable(p, i)]
    if len(batch) > 1:
        leaf_size = check_int_option("leaf_size", options.get("leaf_size", 8), 1, MAX_LEAF_SIZE)
        bins = check_int_option("bins", options.get("bins", 16), 2, MAX_BINS)
        costs = check_costs(options.get("traversal_cost", 1.0), options.get("intersection_cost", 1.0))
        threads = options.get("threads")
        threads = os.cpu_count() or 1 if threads is None else check_int_option("threads", threads, 1, None)
        try:
            for group in batch_groups([len(meshes[j][1]) for j in batch]):
                built = build_binned_batch([meshes[batch[g]] for g in group], use_sah=kind == Builder.SAH,
                                           leaf_size=leaf_size, bins=bins, traversal_cost=costs[0],
                                           intersection_cost=costs[1], builder=kind.value, threads=threads)
                for g, tree in zip(group, built):
                    trees[batch[g]] = tree
        except ValueError:  # build them alone below, for build_bvh's message naming the mesh's triangle
            trees = [None] * len(meshes)
            batch = []
    # Each batched tree's share, by triangles, of everything the batch took (the scan for batchable meshes and the
    # trees' slicing too, most of a batch of thousands of tiny trees), so the trees' times add up to the wall time.
    batched = [trees[j] for j in batch if trees[j] is not None]  # none when one mesh or none could join
    seconds, total = time.perf_counter() - start_time, sum(t.num_prims for t in batched)
    for tree in batched:
        tree.build_seconds = seconds * tree.num_prims / total
    for j, (points, indices) in enumerate(meshes):
        if trees[j] is None:
            trees[j] = build_bvh(points, indices, builder, **options)
    return trees


def check_costs(traversal_cost: float, intersection_cost: float) -> tuple[float, float]:
    """The SAH constants as floats; ValueError unless both are numbers (Python or numpy, a 0-d numpy array of one
    too, not bool or str), finite, ``traversal_cost >= 0`` and ``intersection_cost > 0``. One check for the batched
    and the single build: the batched one took ``"2.0"`` (``float()`` reads it), which the single one refused in
    Python's words. Callers pass on the floats it returns, not what they were given."""
    costs = []
    for name, value in (("traversal_cost", traversal_cost), ("intersection_cost", intersection_cost)):
        # np.array(2.0), which build_bvh took before these checks, is the scalar it holds (a bool, str or complex
        # one is still refused below).
        number = value[()] if isinstance(value, np.ndarray) and value.ndim == 0 else value
        if isinstance(number, (bool, np.bool_)) or not isinstance(number, (int, float, np.integer, np.floating)):
            raise ValueError(f"{name} must be a number, got {value!r}")
        costs.append(float(number))
    traversal_cost, intersection_cost = costs
    if not (0.0 <= traversal_cost < math.inf and 0.0 < intersection_cost < math.inf):
        raise ValueError(
            f"traversal_cost must be finite and >= 0 and intersection_cost finite and > 0, got {traversal_cost!r} "
            f"and {intersection_cost!r}"
        )
    return traversal_cost, intersection_cost


def check_int_option(name: str, value, lo: int, hi: int | None) -> int:
    """``value`` as an int when it is an integer (Python or numpy, not bool) in ``[lo, hi]`` (``hi=None``: no upper
    bound); else ``ValueError`` naming the option. ``int()`` alone truncated 8.7 to 8, took the string ``"8"`` and
    ``True``, and failed on NaN or None with messages that did not name the option. A 0-d numpy array of an integer
    (``np.array(8)``) is that integer, as :func:`check_costs` takes ``np.array(2.0)``; a 0-d bool or float one is
    still refused."""
    number = value[()] if isinstance(value, np.ndarray) and value.ndim == 0 else value
    if isinstance(number, (bool, np.bool_)) or not isinstance(number, (int, np.integer)) or number < lo or (
        hi is not None and number > hi
    ):
        if hi is None:
            raise ValueError(f"{name} must be an integer >= {lo}, got {value!r}")
        raise ValueError(f"{name} must lie in [{lo}, {hi}] and be an integer, got {value!r}")
    return int(number)


def build_bvh_device(
    points,
    indices,
    builder: str = "sah",
    *,
    leaf_size: int = DEFAULT_LEAF_SIZE,
    bins: int = DEFAULT_BINS,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    morton_bits: int = 30,
    ploc_radius: int = 8,
    presplit: int = 0,
    threads: int | None = None,
    device=None,
    timers: dict | None = None,
) -> DeviceFlatBvh:
    """Builds a BVH over triangles and leaves it in the canonical layout in device memory (no host copy).

    Args:
        points: ``(V, 3)`` float32 vertex positions, world space; numpy or ``wp.array`` (on ``device`` it is used
            in place).
        indices: ``(T, 3)`` int32 triangle vertex indices, numpy or ``wp.array``.
        builder: a :class:`Builder` name (see module docstring).
        leaf_size: most triangles in a leaf; the SAH builders and the SAH leaf collapse of ``lbvh``/``ploc`` may
            stop earlier when splitting pays.
        bins: SAH bins per axis for ``sah`` (at most ``MAX_BINS``).
        traversal_cost: SAH cost ``C_t`` of visiting a node, relative to ``intersection_cost``.
        intersection_cost: SAH cost ``C_i`` of one ray-triangle test.
        morton_bits: Morton code length for ``lbvh`` and ``ploc``: 30 (10 bits per axis) or 63 (21 per axis).
        ploc_radius: PLOC nearest-neighbour search radius (clusters on either side in Morton order). 8 gave the
            lowest mean SAH cost over turbineblade, chess_set, bunny, rocks and bear (the paper's 16: +1.3% mean).
        presplit: halve the boxes of long diagonal triangles up to this many times before the build, so each
            becomes up to ``2**presplit`` references with tighter boxes (``presplit.py``); 0: off.
        threads: CPU threads of ``sah``/``middle`` on a CPU device (each level's nodes are split between them;
            Warp's CPU launches are single-threaded); ``None``: every core. The tree does not depend on it.
        device: Warp device to build on; the default device when ``None``.
        timers: if given, ``lbvh`` and ``ploc`` append the milliseconds of each build stage to ``timers[stage]``
            (``wp.ScopedTimer`` with ``synchronize=True``, so timing adds synchronizations).

    Raises:
        ValueError: for an unknown builder, bad options, bad indices or non-finite vertices.
    """
    kind = Builder.from_str(builder)
    leaf_size = check_int_option("leaf_size", leaf_size, 1, MAX_LEAF_SIZE)
    bins = check_int_option("bins", bins, 2, MAX_BINS)
    morton_bits = check_int_option("morton_bits", morton_bits, 0, None)
    if morton_bits not in (30, 63):
        raise ValueError(f"morton_bits must be 30 or 63, got {morton_bits}")
    ploc_radius = check_int_option("ploc_radius", ploc_radius, 1, 64)
    presplit = check_int_option("presplit", presplit, 0, MAX_SPLIT_LEVELS)
    traversal_cost, intersection_cost = check_costs(traversal_cost, intersection_cost)
    if threads is not None:
        threads = check_int_option("threads", threads, 1, None)
    with stage("input checks and triangle boxes", timers):
        data = BuildInput(points, indices, device)
    if data.num_prims == 0:
        empty = FlatBvh.empty(builder=kind.value)
        fields = (empty.lowers, empty.uppers, empty.left_first, empty.prim_count, empty.prim_ids)
        types = (wp.vec3, wp.vec3, wp.int32, wp.int32, wp.int32)
        arrays = [wp.array(a, dtype=t, device=data.device) for a, t in zip(fields, types)]
        return DeviceFlatBvh(*arrays, builder=kind.value)
    ref_prims = plan = None
    if presplit:
        with stage("pre-splits", timers):
            plan = split_plan(data.points, data.indices, presplit)
            data.prim_lowers, data.prim_uppers, data.centroids, ref_prims = write_references(
                data.points, data.indices, *plan)
            data.num_prims = len(ref_prims)
    exponent = unit_exponent(data)  # float32 areas past 1e19 are inf (under 1e-19: 0)
    if exponent:
        scale_input(data, exponent)
    tree = _build(kind, data, leaf_size, bins, morton_bits, ploc_radius, threads, timers,
                  traversal_cost, intersection_cost)
    if exponent:
        scale_boxes_back(tree, exponent)
    if ref_prims is not None:
        if plan[2] > len(plan[0]):  # some triangle was cut: a refit must cut it again (refit.py)
            tree.references = References(plan[0], plan[1], wp.clone(tree.prim_ids), plan[2])
        wp.launch(map_slots_kernel, len(tree.prim_ids), inputs=[ref_prims, tree.prim_ids], device=data.device)
    return tree


def _build(kind, data, leaf_size, bins, morton_bits, ploc_radius, threads, timers, traversal_cost,
           intersection_cost) -> DeviceFlatBvh:
    sah = {"traversal_cost": float(traversal_cost), "intersection_cost": float(intersection_cost)}
    if kind in (Builder.SAH, Builder.MIDDLE):
        from .binned import build_binned

        workers = 1 if data.device.is_cuda else (threads or os.cpu_count() or 1)
        return build_binned(
            data,
            use_sah=kind == Builder.SAH,
            leaf_size=int(leaf_size),
            bins=int(bins),
            builder=kind.value,
            threads=workers,
            **sah,
        )
    if kind in (Builder.SWEEP_SAH, Builder.MEDIAN):
        from .sweep import build_sweep

        return build_sweep(data, use_sah=kind == Builder.SWEEP_SAH, leaf_size=int(leaf_size), builder=kind.value, **sah)
    if kind == Builder.LBVH:
        from .lbvh import build_lbvh

        return build_lbvh(data, leaf_size=int(leaf_size), morton_bits=int(morton_bits), timers=timers, **sah)
    from .ploc import build_ploc

    return build_ploc(
        data, leaf_size=int(leaf_size), morton_bits=int(morton_bits), radius=int(ploc_radius), timers=timers, **sah
    )


__all__ = ["MAX_DEPTH", "Builder", "build_bvh", "build_bvh_device", "build_bvhs", "builder_names"]
