"""GPU build speed of wrt's ``lbvh`` and ``ploc`` against ``wp.Mesh`` on a 10M-triangle displaced sphere, stage by
stage, and the SAH cost of ``ploc`` against ``binned_sah`` on a 1M-triangle one. One self-contained run: it makes
its meshes (``wrt.procedural.displaced_sphere``), prints markdown tables and PASS/MISS lines for the issue's
targets, and finishes in under 3 minutes on an H200, kernel compilation included.

Every time is a ``wp.ScopedTimer(synchronize=True)``, median of ``--repeats`` runs after one warm-up run (kernels
compiled on a small mesh first), the builders taking turns:

- "build": ``build_bvh_device``, the canonical tree left in device memory, as ``wp.Mesh`` leaves its tree;
- "stages": the same build again with ``timers=`` (a synchronization after every stage, so the stages add up to a
  little more than the build);
- "accelerator": ``BvhAccelerator`` of the binary layout, which also uploads the mesh and gathers the triangles in
  slot order on the device (no host round trip on a GPU);
- ``wp.Mesh(bvh_constructor="lbvh")`` (CUDA only) and ``"sah"``;
- "build + wide collapse": the build, then its collapse to the 4-wide layout (``wrt.bvh.collapse``) on the device;
- the accelerator of the ``wide`` layout (``lbvh``): build, collapse and triangles in slot order, on the device.

``binned_sah`` for the SAH-cost comparison is built on ``--binned-device`` (the host CPU by default); the binned
builder gives the same tree on every device (``test_sah_tree_is_the_same_on_every_device``). The GPU-built
``lbvh``/``ploc`` trees of that mesh are checked with ``FlatBvh.validate()`` and compared with the CPU builds.

Usage::

    python benchmarks/gpu_build.py                          # 10M + 1M triangles on cuda:0
    python benchmarks/gpu_build.py --small --device cpu     # 100k + 20k triangles, a dry run anywhere
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
import warp as wp

from wrt.bvh import build_bvh, build_bvh_device
from wrt.bvh.collapse import collapse_wide
from wrt.procedural import displaced_sphere, displaced_sphere_scene
from wrt.scene import Scene
from wrt.trace import BvhAccelerator

SPEED_TARGET = 1.5  # wrt lbvh / ploc build time <= 1.5x wp.Mesh(lbvh)
QUALITY_TARGET = 1.10  # ploc SAH cost within 10% of binned_sah
SLOW_BUILD_SECONDS = 10.0  # a build slower than this in warm-up is timed once (wp.Mesh sah builds on the host)
WIDE = "wrt lbvh accelerator, wide layout"
FIELDS = ("lowers", "uppers", "left_first", "prim_count", "prim_ids")  # FlatBvh arrays compared across devices


def timed(name: str, times: dict, fn) -> float:
    """Runs ``fn`` under a synchronizing ``wp.ScopedTimer``; appends and returns its milliseconds."""
    with wp.ScopedTimer(name, dict=times, print=False, synchronize=True):
        result = fn()
    del result
    return times[name][-1]


def wide_collapse(tree):
    """The 4-wide collapse of a device tree, left on the device."""
    return collapse_wide(tree.lowers, tree.uppers, tree.left_first, tree.prim_count, 4)


def check(label: str, ok: bool, detail: str) -> None:
    print(f"- {'PASS' if ok else 'MISS'}: {label} ({detail})")


def median(values) -> float:
    return statistics.median(values) if values else float("nan")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        allow_abbrev=False,
        description=__doc__.splitlines()[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    parser.add_argument("--device", default="cuda:0", help="device of the timed builds")
    parser.add_argument("--small", action="store_true", help="small meshes (100k timed, 20k for SAH cost)")
    parser.add_argument("--triangles", type=int, help="size of the timed mesh (default 10M, 100k with --small)")
    parser.add_argument("--quality-triangles", type=int, help="size of the SAH-cost mesh (default 1M, 20k)")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per build (median reported)")
    parser.add_argument("--binned-device", default="cpu", help="device of the binned_sah reference build")
    args = parser.parse_args(argv)
    n_timed = args.triangles or (100_000 if args.small else 10_000_000)
    n_quality = args.quality_triangles or (20_000 if args.small else 1_000_000)
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    total_start = time.perf_counter()

    points, indices = displaced_sphere(n_timed)
    print(f"## wrt BVH builds: {len(indices):,} triangles on {device.alias} ({device.name}), warp {wp.config.version}")
    scene = Scene.from_triangles(points, indices)
    pts = wp.array(points, dtype=wp.vec3, device=device)
    idx = wp.array(indices, dtype=wp.int32, device=device)
    idx_flat = idx.reshape((-1,))
    mesh_builders = ["lbvh", "sah"] if device.is_cuda else ["sah"]  # wp.Mesh has no CPU lbvh
    reference = f"wp.Mesh {mesh_builders[0]}"

    builds = {f"wp.Mesh {b}": (lambda b=b: wp.Mesh(pts, idx_flat, bvh_constructor=b)) for b in mesh_builders}
    for b in ("lbvh", "ploc"):
        builds[f"wrt {b} build"] = lambda b=b: build_bvh_device(pts, idx, b, device=device)
        builds[f"wrt {b} accelerator"] = lambda b=b: BvhAccelerator(scene, b, device)
        builds[f"wrt {b} build + wide collapse"] = lambda b=b: wide_collapse(
            build_bvh_device(pts, idx, b, device=device)
        )
    builds[WIDE] = lambda: BvhAccelerator(scene, "lbvh", device, layout="wide")

    # Compile every kernel on a small mesh, then one full-size run of each build (allocator pools, caches).
    small = displaced_sphere(2_000)
    small_scene = displaced_sphere_scene(2_000)
    for b in ("lbvh", "ploc"):
        build_bvh_device(*small, b, device=device)
        BvhAccelerator(small_scene, b, device)
    BvhAccelerator(small_scene, "lbvh", device, layout="wide")
    times, once = {}, set()
    for name, fn in builds.items():
        if timed(name, times, fn) > 1e3 * SLOW_BUILD_SECONDS:
            once.add(name)
        times[name].clear()  # warm-up
    print(f"\ncompiled and warmed up after {time.perf_counter() - total_start:.1f} s\n", flush=True)

    stages = {b: {} for b in ("lbvh", "ploc")}
    for r in range(args.repeats):
        for name, fn in builds.items():
            if name not in once or r == 0:
                timed(name, times, fn)
        for b, timers in stages.items():
            build_bvh_device(pts, idx, b, device=device, timers=timers)

    ref_ms = median(times[reference])
    print(f"### Build time, median of {args.repeats} after a warm-up (ms)\n")
    print(f"| build | median ms | min ms | / {reference} |\n|---|---|---|---|")
    for name, values in times.items():
        note = " (1 run)" if name in once else ""
        print(f"| {name}{note} | {median(values):.1f} | {min(values):.1f} | {median(values) / ref_ms:.2f}x |")
    print("\n### Stages (ms, median; each stage synchronized)\n")
    names = list(dict.fromkeys(s for timers in stages.values() for s in timers))
    print("| stage | lbvh | ploc |\n|---|---|---|")
    for s in names:
        print(f"| {s} | " + " | ".join(f"{median(stages[b][s]):.2f}" if s in stages[b] else "-" for b in stages) + " |")
    sums = [sum(median(v) for v in stages[b].values()) for b in stages]
    print(f"| sum | {sums[0]:.2f} | {sums[1]:.2f} |\n")
    for name in (
        "wrt lbvh build",
        "wrt ploc build",
        "wrt lbvh build + wide collapse",
        "wrt ploc build + wide collapse",
    ):
        ratio = median(times[name]) / ref_ms
        check(f"{name} <= {SPEED_TARGET}x {reference}", ratio <= SPEED_TARGET, f"{ratio:.2f}x")
    sys.stdout.flush()

    # SAH cost on the smaller mesh; the GPU trees must be valid and should match the CPU builds.
    q_points, q_indices = displaced_sphere(n_quality)
    print(f"\n### SAH cost, {len(q_indices):,} triangles (C_t = C_i = 1, leaf_size 8 with SAH leaf collapse)\n")
    trees = {f"wrt {b}": build_bvh(q_points, q_indices, b, device=device) for b in ("lbvh", "ploc")}
    start = time.perf_counter()
    trees["wrt binned_sah"] = build_bvh(q_points, q_indices, "sah", device=args.binned_device)
    binned_seconds = time.perf_counter() - start
    print("| tree | SAH cost | / binned_sah | nodes | leaves | max depth | same tree as a CPU build |")
    print("|---|---|---|---|---|---|---|")
    binned_cost = trees["wrt binned_sah"].stats(epo_samples=0)["sah_cost"]
    costs = {}
    for name, tree in trees.items():
        tree.validate()
        s = tree.stats(epo_samples=0)
        costs[name] = s["sah_cost"]
        same = "(reference)"
        if name != "wrt binned_sah":
            cpu = tree if device.is_cpu else build_bvh(q_points, q_indices, name.split()[-1], device="cpu")
            same = "yes" if all(np.array_equal(getattr(tree, f), getattr(cpu, f)) for f in FIELDS) else "no"
        print(
            f"| {name} | {s['sah_cost']:.3f} | {s['sah_cost'] / binned_cost:.4f} | {s['nodes']} | {s['leaves']} "
            f"| {s['max_depth']} | {same} |"
        )
    print(f"\n(binned_sah built on {args.binned_device} in {binned_seconds:.1f} s; every tree passed validate())\n")
    ratio = costs["wrt ploc"] / binned_cost
    check(
        f"ploc SAH within {100 * (QUALITY_TARGET - 1):.0f}% of binned_sah", ratio <= QUALITY_TARGET, f"{ratio - 1:+.2%}"
    )
    print(f"\ntotal {time.perf_counter() - total_start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
