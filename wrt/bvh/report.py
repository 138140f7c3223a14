"""Side-by-side BVH statistics for one mesh: wrt's builders and Warp's own trees (``warp:sah``, ``warp:median``,
``warp:lbvh``, ``warp:cubql``), and the ``wrt bvh-stats`` command built on them.

Every row is a :meth:`FlatBvh.stats` dict (Warp's trees are read through ``warp_mesh.read_warp_bvh`` into the same
canonical layout), so both sides are measured by the same code under the same cost constants.
"""

from __future__ import annotations

import inspect
import math

from ..errors import did_you_mean
from ..strict_json import strict_json
from ..wording import counted
from .build import Builder, build_bvh, build_bvh_device, builder_names, check_costs
from .layout import LAYOUTS, convert_layout
from .warp_mesh import WARP_BUILDERS

WARP_PREFIX = "warp:"  # builder names of the form "warp:<bvh_constructor>" read wp.Mesh's tree


def parse_builders(text) -> list[str]:
    """Builder names from a comma-separated list (or a list of them); ``all`` means every wrt builder.

    Raises:
        ValueError: for an unknown wrt or Warp builder name.
    """
    items = text if isinstance(text, (list, tuple)) else [text]
    names = []
    for item in items:
        for name in str(item).split(","):
            name = name.strip()
            if not name:
                continue
            if name == "all":
                names += [b.value for b in Builder]
            elif name.startswith(WARP_PREFIX):
                if name[len(WARP_PREFIX) :] not in WARP_BUILDERS:
                    valid = [WARP_PREFIX + b for b in WARP_BUILDERS]
                    raise ValueError(f"unknown Warp builder {name!r}{did_you_mean(name, valid)}; valid Warp builders: "
                                     f"{', '.join(valid)}")
                names.append(name)
            else:
                try:
                    names.append(Builder.from_str(name).value)
                except ValueError:  # matched against wrt's builders alone, 'wrp:sah' meant 'sweep_sah'
                    every = [*builder_names(), "all", *(WARP_PREFIX + b for b in WARP_BUILDERS)]
                    raise ValueError(f"unknown BVH builder {name!r}{did_you_mean(name, every)}; valid builders: "
                                     f"{', '.join(every)}") from None
    if not names:
        raise ValueError(f"no builder given; valid builders: {', '.join(builder_names())}, all, warp:<name>")
    return list(dict.fromkeys(names))


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
            trace use ``wrt.trace.ACCELERATOR_PRESPLIT``. EPO is not estimated for them (``None``): a triangle may
            sit in several leaves.
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


def _builders(text: str) -> str:
    """An argparse type: one ``--builder`` value, comma-separated names :func:`parse_builders` reads."""
    import argparse

    try:
        parse_builders(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text


def _non_negative_float(text: str) -> float:
    """An argparse type: a finite number at least 0 (``--traversal-cost``)."""
    import argparse

    from ..cli import _finite_float

    value = _finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a number at least 0, got {text}")
    return value


def add_bvh_stats(sub) -> None:
    """Adds the ``bvh-stats`` subcommand to an argparse sub-parser set."""
    from ..cli import HelpFormatter, _finite_float, _non_empty, _positive_float, add_stage_options, int_at_least
    from ..trace import ACCELERATOR_PRESPLIT
    from .common import MAX_BINS, MAX_LEAF_SIZE
    from .presplit import MAX_SPLIT_LEVELS
    from .stats import MAX_EPO_SAMPLES
    from .warp_mesh import MAX_WARP_LEAF_SIZE

    # Each value is checked as it is read, so an error names the option typed (it named the Python argument, as
    # 'presplit must lie in [0, 6]', and came after the scene's load).
    def up_to(lo: int, hi: int):
        return int_at_least(lo, f"an integer from {lo} to {hi}", hi)

    p = sub.add_parser(
        "bvh-stats",
        help="BVH quality and size statistics of a scene, for wrt's builders and Warp's",
        description="Build BVHs over a USD scene's triangles (gprims tessellated) and report SAH cost, EPO "
        "(end-point overlap, estimated), node and leaf counts, depths, leaf sizes, bytes and build time. Warp's "
        "own trees are read from wp.Mesh with --builder warp:sah (or warp:median, warp:lbvh on CUDA, warp:cubql).",
        formatter_class=HelpFormatter,
    )
    p.add_argument("scene", type=_non_empty, help="USD file (.usd, .usda, .usdc, .usdz)")
    p.add_argument(
        "--builder",
        action="append",
        type=_builders,
        help=f"builders, comma-separated or repeated: {', '.join(builder_names())}, all, or warp:<name> for "
        "wp.Mesh's tree (default: sah)",
    )
    p.add_argument("--layout", default="binary", choices=LAYOUTS, help="layout whose node count and bytes are shown")
    built = inspect.signature(build_bvh_device).parameters  # the builders' defaults, which an option left out keeps
    p.add_argument("--leaf-size", type=up_to(1, MAX_LEAF_SIZE), default=None,
                   help=f"wrt's most triangles per leaf (default {built['leaf_size'].default})")
    p.add_argument("--warp-leaf-size", type=up_to(1, MAX_WARP_LEAF_SIZE), default=None,
                   help="Warp's bvh_leaf_size (default: Warp's)")
    p.add_argument("--bins", type=up_to(2, MAX_BINS), default=None, help="SAH bins per axis for sah (default "
                   f"{built['bins'].default})")
    p.add_argument("--traversal-cost", type=_non_negative_float, default=1.0, help="SAH constant C_t (node visit)")
    p.add_argument("--intersection-cost", type=_positive_float, default=1.0, help="SAH constant C_i (triangle test)")
    p.add_argument("--epo-samples", type=up_to(1, MAX_EPO_SAMPLES), default=1 << 16,
                   help="surface samples of the EPO estimate")
    p.add_argument("--presplit", type=up_to(0, MAX_SPLIT_LEVELS), default=0,
                   help="pre-split levels of wrt's builds: long diagonal triangles become up to 2**K references; the "
                   f"sah trees of renders and wrt bench use {ACCELERATOR_PRESPLIT}; no EPO for trees so built")
    p.add_argument("--device", default="cpu", type=_non_empty, help="Warp device to build on, e.g. cpu or cuda:0")
    p.add_argument("--time", type=_finite_float, default=None, help="USD time code; default: the default time")
    add_stage_options(p)
    p.add_argument("--json", action="store_true", help="print JSON rows instead of a table")
    p.set_defaults(run=run_bvh_stats)


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
