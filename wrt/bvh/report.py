"""Side-by-side BVH statistics for one mesh: wrt's builders and Warp's own trees (``warp:sah``, ``warp:median``,
``warp:lbvh``, ``warp:cubql``), and the ``wrt bvh-stats`` command built on them.

Every row is a :meth:`FlatBvh.stats` dict (Warp's trees are read through ``warp_mesh.read_warp_bvh`` into the same
canonical layout), so both sides are measured by the same code under the same cost constants.
"""

from __future__ import annotations

import math

from ..options import WARP_PREFIX, parse_builders
from ..strict_json import strict_json
from ..wording import counted
from .build import build_bvh, check_costs
from .layout import convert_layout


def collect_stats(
    points,
    indices,
    builders,
    *,
    layout: str = "binary",
    leaf_size: int | None = None,
    warp_leaf_size: int | None = None,
    bins: int | None = None,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    epo_samples: int | None = None,
    presplit: int = 0,
    device="cpu",
) -> list[dict]:
    """One statistics row per builder over the triangles ``points[indices]``.

    Args:
        points: ``(V, 3)`` float32 vertices.
        indices: ``(T, 3)`` int32 triangles.
        builders: names as accepted by :func:`parse_builders`.
        layout: layout whose node count and bytes are added as ``layout_nodes`` / ``layout_bytes``.
        leaf_size: wrt's ``leaf_size`` (its default when ``None``).
        warp_leaf_size: Warp's ``bvh_leaf_size`` (Warp's default when ``None``).
        bins: SAH bins of ``sah`` (its default when ``None``).
        traversal_cost: SAH/EPO ``C_t``, also used by the SAH builders.
        intersection_cost: SAH/EPO ``C_i``.
        epo_samples: surface samples of the EPO estimate (default when ``None``).
        presplit: pre-split levels of wrt's builds (``wrt.build_bvh``); the SAH trees that renders and ``wrt bench``
            trace use ``wrt.trace.ACCELERATOR_PRESPLIT``. EPO is not estimated (``None``) for a tree whose pre-splits
            split a triangle, which then sits in several leaves; where they split none, it is.
        device: Warp device to build on.
    """
    from .warp_mesh import warp_mesh_bvh

    traversal_cost, intersection_cost = check_costs(traversal_cost, intersection_cost)  # Warp's trees use them too
    rows = []
    for name in parse_builders(builders):
        if name.startswith(WARP_PREFIX):
            bvh = warp_mesh_bvh(points, indices, name[len(WARP_PREFIX) :], warp_leaf_size, device)
        else:
            options = {key: int(value) for key, value in (("leaf_size", leaf_size), ("bins", bins))
                       if value is not None}
            bvh = build_bvh(
                points,
                indices,
                name,
                traversal_cost=traversal_cost,
                intersection_cost=intersection_cost,
                presplit=presplit,
                device=device,
                **options,
            )
        bvh.validate()
        split = bvh.num_prims != len(indices)  # the EPO estimate needs each triangle in one leaf
        row = bvh.stats(traversal_cost, intersection_cost, epo_samples=0 if split else epo_samples)
        converted = convert_layout(bvh, layout)
        row.update(layout=layout, layout_nodes=int(converted.num_nodes), layout_bytes=int(converted.bytes))
        rows.append(row)
    return rows


def histogram_text(histogram: dict, limit: int = 8) -> str:
    """``size:count`` pairs of a leaf-size histogram, the ``limit`` smallest sizes."""
    items = sorted(histogram.items())
    text = " ".join(f"{s}:{c}" for s, c in items[:limit])
    return text + (" ..." if len(items) > limit else "")


def format_table(rows: list[dict]) -> str:
    """A markdown table of statistics rows. ``nodes`` and ``leaves`` are the binary tree's; ``layout nodes`` and
    ``layout MB`` those of the ``--layout`` it converts to (a wide8 tree has about a tenth of the binary nodes)."""
    header = (
        "| builder | build s | SAH cost | EPO | nodes | leaves | max depth | mean leaf depth | layout | layout nodes "
        "| layout MB | leaf sizes (size:leaves) |"
    )
    lines = [header, "|" + "|".join(["---"] * (header.count("|") - 1)) + "|"]
    for r in rows:
        # No EPO (not estimated, or NaN where the triangles have no area) reads 'n/a', as wrt bench's table has it.
        epo = "n/a" if r["epo"] is None or not math.isfinite(r["epo"]) else f"{r['epo']:.3f}"
        lines.append(
            f"| {r['builder']} | {r['build_seconds']:.3f} | {r['sah_cost']:.2f} | {epo} | {r['nodes']} | {r['leaves']} "
            f"| {r['max_depth']} | {r['mean_leaf_depth']:.1f} | {r['layout']} | {r['layout_nodes']} "
            f"| {r['layout_bytes'] / 1e6:.1f} "
            f"| {histogram_text(r['leaf_size_histogram'])} |"
        )
    return "\n".join(lines)


def warn_unused_builder_options(args, builders: list[str]) -> None:
    """One warning per builder option given that no builder of ``builders`` (canonical names) uses: it was ignored
    without a word (``--bins 4 --builder median`` reported the median tree as if binned)."""
    import warnings

    wrt_builders = [b for b in builders if not b.startswith(WARP_PREFIX)]
    for option, value, who_uses, used in (
        ("--bins", args.bins, "the sah builder uses", "sah" in builders),
        ("--leaf-size", args.leaf_size, "wrt's builders (not warp:<name>) use", bool(wrt_builders)),
        ("--warp-leaf-size", args.warp_leaf_size, "Warp's builders (warp:<name>) use",
         len(wrt_builders) < len(builders)),
    ):
        if value is not None and not used:
            warnings.warn(f"{option} is ignored: only {who_uses} it, and the builders here are {', '.join(builders)}")


def run_bvh_stats(args) -> int:
    """Runs ``wrt bvh-stats``; returns the exit status."""
    import sys

    import wrt

    from ..cli import stage_options
    from .common import resolve_device_option

    builders = parse_builders(args.builder or ["sah"])
    warn_unused_builder_options(args, builders)
    device = resolve_device_option(args.device)
    # Gprims as triangle meshes, as wrt bench measures them: loaded as analytic shapes they are in no BVH over
    # triangles, and a stage of spheres and cubes reported an empty tree.
    scene = wrt.load_usd(args.scene, time=args.time, tessellate_gprims=True, **stage_options(args))
    points, indices = scene.triangles()
    rows = collect_stats(
        points,
        indices,
        builders,
        layout=args.layout,
        leaf_size=args.leaf_size,
        warp_leaf_size=args.warp_leaf_size,
        bins=args.bins,
        traversal_cost=args.traversal_cost,
        intersection_cost=args.intersection_cost,
        epo_samples=args.epo_samples,
        presplit=args.presplit,
        device=device,
    )
    if args.json:
        print(strict_json(rows, indent=1))  # a statistic without a value (EPO without area is NaN) is null
    else:
        print(
            f"{args.scene}: {counted(len(indices), 'triangle')}; SAH/EPO with C_t={args.traversal_cost}, "
            f"C_i={args.intersection_cost}; device {device}"
        )
        print(format_table(rows))
    sys.stdout.flush()
    return 0
